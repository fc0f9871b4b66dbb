#include "fringe/scan/truth.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "fringe/io/calibration_io.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::scan {
namespace {

TEST(Truth, PosesMarkersAndSceneRoundTrip) {
  test::TempDir dir;
  TruthPoses poses;
  poses.turntable = true;
  poses.views.push_back(
      {"000", Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())),
                      Eigen::Vector3d(1, 2, 3))});
  poses.views.push_back({"001", Rigid3d()});
  WriteTruthPoses(dir / "poses.json", poses);
  const TruthPoses p = ReadTruthPoses(dir / "poses.json");
  EXPECT_TRUE(p.turntable);
  ASSERT_EQ(p.views.size(), 2u);
  EXPECT_LT((p.Find("000")->world_from_sensor.translation() - Eigen::Vector3d(1, 2, 3)).norm(),
            1e-12);
  EXPECT_LT(p.Find("000")->world_from_sensor.rotation().angularDistance(
                poses.views[0].world_from_sensor.rotation()),
            1e-12);
  EXPECT_EQ(p.Find("002"), nullptr);

  TruthMarkers markers;
  markers.markers.push_back({4, {1, 2, 3}, {0, 0, 1}, 1.5, 2.5});
  MarkerObservation o;
  o.id = 4;
  o.centre_in_sensor = {10, 20, 500};
  o.left_px = {100.25, 200.5};
  o.right_px = Eigen::Vector2d::Constant(std::nan(""));  // behind the camera: null
  o.visible_left = true;
  markers.views.push_back({"000", {o}});
  WriteTruthMarkers(dir / "markers.json", markers);
  const TruthMarkers m = ReadTruthMarkers(dir / "markers.json");
  ASSERT_EQ(m.markers.size(), 1u);
  EXPECT_EQ(m.markers[0].centre_in_world, Eigen::Vector3d(1, 2, 3));
  const MarkerObservation& r = m.Find("000")->observations.at(0);
  EXPECT_EQ(r.left_px, o.left_px);
  EXPECT_TRUE(std::isnan(r.right_px.x()));
  EXPECT_TRUE(r.visible_left);
  EXPECT_FALSE(r.visible_right);

  TruthScene scene;
  scene.scene = "vdi";
  scene.objects.push_back({"sphere", 0.75, 100, TruthSphere{{1, 2, 3}, 15}});
  scene.objects.push_back({"board", std::nullopt, 2, std::nullopt});
  WriteTruthScene(dir / "scene.json", scene);
  const TruthScene s = ReadTruthScene(dir / "scene.json");
  EXPECT_EQ(s.Find("sphere")->sphere->radius_mm, 15);
  EXPECT_FALSE(s.Find("board")->albedo.has_value());
  EXPECT_EQ(s.mesh, "scene.ply");
}

TEST(Truth, BadRecordsNameFileAndField) {
  auto expect = [](const nlohmann::json& j, auto parse, const std::string& what) {
    try {
      parse(j, "truth/x.json");
      ADD_FAILURE() << "accepted: " << j.dump();
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("truth/x.json"), std::string::npos) << msg;
      EXPECT_NE(msg.find(what), std::string::npos) << msg;
    }
  };
  const nlohmann::json pose = io::RigidToJson(Rigid3d());
  expect({{"views",
           {{{"view", "000"}, {"world_from_sensor", pose}},
            {{"view", "000"}, {"world_from_sensor", pose}}}}},
         PosesFromJson, "listed twice");
  expect({{"views", 3}}, PosesFromJson, "'views' must be an array");
  const nlohmann::json marker = {{"id", 1},
                                 {"centre_in_world", {0, 0, 0}},
                                 {"normal_in_world", {0, 0, 1}},
                                 {"inner_radius_mm", 3.0},
                                 {"outer_radius_mm", 2.0}};
  expect({{"markers", {marker}}, {"views", nlohmann::json::array()}}, MarkersFromJson, "radii");
  nlohmann::json bad_vec = marker;
  bad_vec["inner_radius_mm"] = 1.0;
  bad_vec["centre_in_world"] = {0, 0};
  expect({{"markers", {bad_vec}}, {"views", nlohmann::json::array()}}, MarkersFromJson,
         "centre_in_world");
  nlohmann::json ok = marker;
  ok["inner_radius_mm"] = 1.0;
  const nlohmann::json unknown_obs = {{"id", 9},
                                      {"centre_in_sensor", {0, 0, 1}},
                                      {"left_px", nullptr},
                                      {"right_px", nullptr},
                                      {"visible_left", false},
                                      {"visible_right", false}};
  expect({{"markers", {ok}}, {"views", {{{"view", "000"}, {"observations", {unknown_obs}}}}}},
         MarkersFromJson, "not in 'markers'");
  expect({{"scene", "s"},
          {"mesh", "scene.ply"},
          {"objects",
           {{{"name", "ball"},
             {"albedo", 0.5},
             {"triangles", 1},
             {"sphere", {{"centre_in_world", {0, 0, 0}}, {"radius_mm", -1}}}}}}},
         SceneFromJson, "radius_mm");
}

}  // namespace
}  // namespace fringe::scan
