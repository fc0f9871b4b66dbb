#include "fringe/pipeline/report.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "fringe/sim/scene.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::pipeline {
namespace {

TEST(Report, RenderedBoxFillsItsSilhouette) {
  // A 20 mm cube seen along -x: its silhouette is a square of 20 mm in a frame of
  // 2.1 x the bounding radius (17.3 mm) on the shorter side.
  const TriangleMesh box =
      sim::MakeBoxMesh(Eigen::Vector3d(-10, -10, -10), Eigen::Vector3d(10, 10, 10));
  const cv::Mat img = RenderMesh(box, Eigen::Vector3d(-1, 0, 0), 200, 200);
  const double mm_per_px = 2.1 * std::sqrt(300.0) / 200;
  const double expected_px = std::pow(20 / mm_per_px, 2);
  EXPECT_NEAR(cv::countNonZero(img), expected_px, 0.05 * expected_px);
  EXPECT_EQ(img.at<uint8_t>(0, 0), 0);       // background
  EXPECT_GT(img.at<uint8_t>(100, 100), 40);  // the lit face
}

TEST(Report, RenderingsOfOneRendererDoNotDependOnTheThreadCount) {
  // The rows are cast in parallel; one thread and all threads give the same pictures, and the
  // renderer's pictures equal the free functions'.
  const TriangleMesh box =
      sim::MakeBoxMesh(Eigen::Vector3d(-10, -10, -10), Eigen::Vector3d(10, 12, 14));
  std::vector<double> values;
  for (const Eigen::Vector3d& v : box.vertices) values.push_back(v.z() / 14);
  const MeshRenderer renderer(box);
  const Eigen::Vector3d dir = Eigen::Vector3d(-1, 0.5, -0.7).normalized();
  const cv::Mat all = renderer.Render(dir, 160, 120);
  const cv::Mat all_coloured = renderer.RenderColoured(values, -1, 1, "mm", dir, 160, 120);
  cv::Mat one, one_coloured;
  tbb::task_arena(1).execute([&] {
    one = renderer.Render(dir, 160, 120);
    one_coloured = renderer.RenderColoured(values, -1, 1, "mm", dir, 160, 120);
  });
  EXPECT_GT(cv::countNonZero(all), 1000);
  EXPECT_EQ(cv::norm(all, one, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(all_coloured, one_coloured, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(all, RenderMesh(box, dir, 160, 120), cv::NORM_INF), 0);
}

TEST(Report, ColouredRenderingFollowsTheVertexValues) {
  // A square in the plane z = 0 seen from above, its value rising with x: the left of the
  // picture is blue (low), the right red (high); a colour bar is appended below.
  TriangleMesh square;
  square.vertices = {{-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0}};
  square.triangles = {{0, 1, 2}, {0, 2, 3}};
  const std::vector<double> values = {-1, 1, 1, -1};
  const cv::Mat img =
      RenderMeshColoured(square, values, -1, 1, "mm", Eigen::Vector3d(0, 0, -1), 200, 200);
  ASSERT_EQ(img.type(), CV_8UC3);
  EXPECT_GT(img.rows, 200);  // the bar
  const cv::Vec3b left = img.at<cv::Vec3b>(100, 40), right = img.at<cv::Vec3b>(100, 160);
  EXPECT_GT(left[0], left[2]);                             // blue-ish (BGR)
  EXPECT_GT(right[2], right[0]);                           // red-ish
  EXPECT_EQ(img.at<cv::Vec3b>(2, 2), cv::Vec3b(0, 0, 0));  // background
  EXPECT_THROW(RenderMeshColoured(square, {1, 2}, -1, 1, "mm", Eigen::Vector3d(0, 0, -1)), Error);
}

// An array of a scene, decoded from its block.
template <typename T>
std::vector<T> SceneArray(const ReportScene& scene, const std::string& name) {
  const nlohmann::json& a = scene.description.at("arrays").at(name);
  std::vector<T> out(a.at("count").get<size_t>());
  std::memcpy(out.data(), scene.bytes().data() + a.at("offset").get<size_t>(),
              out.size() * sizeof(T));
  return out;
}

TEST(Report, ScanSceneHoldsTheDecimatedMeshAndTheValuesOfItsNearestPoints) {
  // A gently curved 100 x 100 mm patch of 20,000 triangles (1 mm grid) 400 mm from the world
  // origin; per vertex a known deviation (x / 100 mm). The fused points are its vertices: those
  // with x < 0 from view "a", the others from "b" (fusion's view order b, a: the scene maps
  // them to its sensors' order), support 2 in the middle, quality = y.
  TriangleMesh mesh;
  const int n = 101;
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      const double x = c - 50.0, y = r - 50.0;
      mesh.vertices.emplace_back(x, y, 400 + 0.002 * (x * x + y * y));
    }
  }
  for (int r = 0; r + 1 < n; ++r) {
    for (int c = 0; c + 1 < n; ++c) {
      const int v = r * n + c;
      mesh.triangles.push_back({v, v + 1, v + n + 1});
      mesh.triangles.push_back({v, v + n + 1, v + n});
    }
  }
  std::vector<double> deviation;
  PointCloud fused;
  std::vector<uint16_t> support, view;
  for (const Eigen::Vector3d& p : mesh.vertices) {
    deviation.push_back(p.x() / 100);
    fused.points.push_back(p);
    fused.quality.push_back(static_cast<float>(p.y()));
    support.push_back(std::abs(p.x()) < 10 ? 2 : 1);
    view.push_back(p.x() < 0 ? 1 : 0);  // fusion's views: 0 = "b", 1 = "a"
  }
  ScanSceneInput in;
  in.mesh = &mesh;
  in.mesh_deviation_mm = &deviation;
  in.deviation_range = DeviationRange::FromTolerance(0.25);
  in.fused = &fused;
  in.fused_support = &support;
  in.fused_view = &view;
  in.fused_view_names = {"b", "a"};
  const CameraModel camera = CameraModel::ReferenceCamera();
  in.sensors = {{"a", Rigid3d(), camera}, {"b", Rigid3d(), camera}};
  in.markers = {{7, Eigen::Vector3d(1, 2, 400), 3, 2}};
  ScanSceneOptions options;
  options.max_triangles = 2000;
  options.max_points = 5000;
  const ReportScene scene = ScanScene(in, options);
  const nlohmann::json& d = scene.description;

  // The mesh, decimated; its vertices on the patch (origin added back).
  const size_t triangles = d.at("mesh").at("triangles").get<size_t>();
  EXPECT_LE(triangles, 2000u);
  EXPECT_GT(triangles, 1000u);
  EXPECT_EQ(d.at("mesh").at("full_triangles"), 20000);
  const Eigen::Vector3d origin(d["origin"][0], d["origin"][1], d["origin"][2]);
  EXPECT_NEAR(origin.z(), 405, 0.5);  // the middle of the bounding box, rounded
  const std::vector<float> p = SceneArray<float>(scene, "mesh.positions");
  const std::vector<uint32_t> idx = SceneArray<uint32_t>(scene, "mesh.indices");
  ASSERT_EQ(idx.size(), 3 * triangles);
  const size_t vertices = p.size() / 3;
  for (uint32_t i : idx) ASSERT_LT(i, vertices);
  const std::vector<float> dev = SceneArray<float>(scene, "mesh.deviation");
  const std::vector<uint16_t> mesh_view = SceneArray<uint16_t>(scene, "mesh.view");
  const std::vector<float> quality = SceneArray<float>(scene, "mesh.quality");
  ASSERT_EQ(dev.size(), vertices);
  ASSERT_EQ(mesh_view.size(), vertices);
  for (size_t v = 0; v < vertices; ++v) {
    const Eigen::Vector3d q = origin + Eigen::Vector3d(p[3 * v], p[3 * v + 1], p[3 * v + 2]);
    ASSERT_NEAR(q.z(), 400 + 0.002 * (q.x() * q.x() + q.y() * q.y()), 0.05);
    // The nearest full vertex lies within half a grid step in x (deviation x / 100).
    ASSERT_NEAR(dev[v], q.x() / 100, 0.0051 + 1e-6);
    ASSERT_NEAR(quality[v], q.y(), 0.51);
    // Sensor order: "a" is 0 (x < 0), "b" is 1.
    if (std::abs(q.x()) > 0.6) {
      ASSERT_EQ(mesh_view[v], q.x() < 0 ? 0 : 1) << q.transpose();
    }
  }
  // The points: a sample of at most 5000, with their values.
  EXPECT_LE(d.at("points").at("count").get<size_t>(), 5000u);
  EXPECT_EQ(d.at("points").at("total"), n * n);
  EXPECT_EQ(SceneArray<uint16_t>(scene, "points.view").size(), d["points"]["count"].get<size_t>());
  // The colourings, deviation first with the tolerance's range and legend.
  std::vector<std::string> ids;
  for (const nlohmann::json& k : d.at("colourings")) ids.push_back(k.at("id"));
  EXPECT_EQ(ids, (std::vector<std::string>{"deviation", "height", "view", "support", "quality"}));
  EXPECT_EQ(d["colourings"][0]["range"], nlohmann::json({-0.25, 0.25}));
  EXPECT_NE(d["colourings"][0]["label"].get<std::string>().find("tolerance"), std::string::npos);
  EXPECT_EQ(d["colourings"][2]["names"], nlohmann::json({"a", "b"}));
  EXPECT_EQ(d["colourings"][3]["range"], nlohmann::json({1, 2}));
  ASSERT_EQ(d.at("views").size(), 2u);
  EXPECT_EQ(d["views"][0]["name"], "a");
  EXPECT_EQ(d["markers"][0]["id"], 7);
  EXPECT_EQ(d["markers"][0]["views"], 2);

  // Values that do not fit the mesh or the points are refused.
  std::vector<double> short_deviation(10, 0.0);
  in.mesh_deviation_mm = &short_deviation;
  EXPECT_THROW(ScanScene(in, options), Error);
  in.mesh_deviation_mm = &deviation;
  std::vector<uint16_t> short_view(10, 0);
  in.fused_view = &short_view;
  EXPECT_THROW(ScanScene(in, options), Error);
  options.max_triangles = 3;
  EXPECT_THROW(ScanScene(in, options), Error);
}

}  // namespace
}  // namespace fringe::pipeline
