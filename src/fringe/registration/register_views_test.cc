#include "fringe/registration/register_views.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <tuple>

#include "fringe/io/ply.h"
#include "fringe/registration/registration_io.h"
#include "fringe/registration/test_views.h"
#include "fringe_test.h"

namespace fringe::registration {
namespace {

// Quarter-resolution views (one pixel ~0.8 mm on the part, depth noise ~0.1 mm): pose figures
// are a few times looser than the full-resolution targets of bench_registration.
constexpr double kRotTolDeg = 0.02;
constexpr double kCentroidTolMm = 0.05;
constexpr double kMarkerOnlyRotTolDeg = 0.1;

struct Fixture {
  StereoRig rig = testing::SmallRig();
  std::vector<Rigid3d> truth;  // world_from_sensor
  std::vector<RegistrationView> views;
};

// Plane, box and sphere with a ring of markers on the plane, seen from four sides at 60 degrees
// elevation: every view shares >= 3 markers with its neighbours.
const Fixture& Views() {
  static const Fixture* f = [] {
    auto* fx = new Fixture;
    sim::Scene scene = testing::PlaneWithBox();
    sim::SceneObject ball;
    ball.name = "ball";
    const sim::Sphere sphere{Eigen::Vector3d(45, 40, 20), 20};
    ball.mesh = sim::MakeSphereMesh(sphere, 0.05);
    ball.sphere = sphere;
    scene.AddObject(ball);
    // Two turned boxes: walls facing many directions, so that ICP has every direction
    // constrained (plane, box top and sphere alone leave turns about the sphere's vertical free).
    for (const auto& [centre, size, angle] :
         std::vector<std::tuple<Eigen::Vector3d, Eigen::Vector3d, double>>{
             {{-45, 35, 0}, {18, 12, 15}, 0.5}, {{15, -48, 0}, {22, 14, 12}, -0.35}}) {
      sim::SceneObject b;
      b.name = "turned_box";
      b.mesh = sim::MakeBoxMesh(-0.5 * size, 0.5 * size);
      b.mesh.Transform(Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitZ(), angle,
                                              centre + Eigen::Vector3d(0, 0, 0.5 * size.z())));
      b.albedo = 0.55;
      scene.AddObject(b);
    }
    int id = 0;
    for (int k = 0; k < 14; ++k) {
      const double a = 2 * M_PI * k / 14 + 0.1 * (k % 3);
      const double r = k % 2 ? 104 : 92;
      scene.AddMarker(testing::MakeMarker(id++, {r * std::cos(a), r * std::sin(a), 0}));
    }
    for (int v = 0; v < 4; ++v) {
      const double az = M_PI / 2 * v + 0.3, el = M_PI / 3;
      const Eigen::Vector3d from(std::cos(az) * std::cos(el), std::sin(az) * std::cos(el),
                                 std::sin(el));
      const Rigid3d pose =
          sim::SensorPoseLookingAt(fx->rig, Eigen::Vector3d(0, 0, 10), from, 0.1 * v);
      const testing::SimulatedView sv = testing::SimulateView(fx->rig, scene, pose, v);
      RegistrationView rv;
      rv.name = "view" + std::to_string(v);
      rv.cloud = sv.rec.cloud.Compact();
      rv.markers =
          DetectViewMarkers(fx->rig, sv.rec.texture_left, sv.rec.texture_right, sv.rec.cloud)
              .markers;
      fx->truth.push_back(pose);
      fx->views.push_back(std::move(rv));
    }
    return fx;
  }();
  return *f;
}

// Pose error of view v with the world fixed at view 0 (the registration's gauge): rotation
// angle, and displacement of the view's cloud centroid.
RigidDifference PoseError(const Fixture& f, const std::vector<Rigid3d>& est, int v) {
  const Rigid3d true_pose = f.truth[0].Inverse() * f.truth[v];
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : f.views[v].cloud.points) c += p;
  c /= static_cast<double>(f.views[v].cloud.size());
  RigidDifference d;
  d.angle_rad = (true_pose.rotation().inverse() * est[v].rotation())
                    .angularDistance(Eigen::Quaterniond::Identity());
  d.translation_mm = (est[v] * c - true_pose * c).norm();
  return d;
}

std::vector<Rigid3d> Poses(const RegistrationResult& r) {
  std::vector<Rigid3d> p;
  for (const auto& v : r.views) p.push_back(v.world_from_sensor);
  return p;
}

TEST(RegistrationOptions, DefaultsPassCheck) { EXPECT_NO_THROW(RegistrationOptions().Check()); }
TEST(IcpOptions, DefaultsPassCheck) { EXPECT_NO_THROW(IcpOptions().Check()); }

TEST(RegisterViews, MarkersThenIcpRecoverTheTruePoses) {
  const Fixture& f = Views();
  for (const auto& v : f.views) ASSERT_GE(v.markers.size(), 5u) << v.name;
  const RegistrationResult r = RegisterViews(f.views);
  ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
  EXPECT_EQ(r.views[0].path, ViewPath::kWorld);
  for (int v = 1; v < 4; ++v) {
    EXPECT_EQ(r.views[v].path, ViewPath::kMarkers) << r.views[v].message;
    std::vector<Rigid3d> marker_only;
    for (const auto& x : r.views) marker_only.push_back(x.world_from_sensor_markers);
    EXPECT_LT(PoseError(f, marker_only, v).angle_rad * 180 / M_PI, kMarkerOnlyRotTolDeg);
    const RigidDifference d = PoseError(f, Poses(r), v);
    EXPECT_LT(d.angle_rad * 180 / M_PI, kRotTolDeg) << "view " << v;
    EXPECT_LT(d.translation_mm, kCentroidTolMm) << "view " << v;
    EXPECT_GT(r.views[v].overlap_fraction, 0.1);
  }
  // The map: every true marker seen twice or more is one map marker.
  EXPECT_TRUE(r.summary.adjustment.ok()) << r.summary.adjustment.BriefReport();
  EXPECT_LT(r.summary.adjustment.rms_final_mm, 0.1);  // marker centres ~0.05 mm apart
  // The threshold schedule shrinks, and the residual falls.
  const auto& levels = r.summary.icp.levels;
  ASSERT_FALSE(levels.empty()) << r.summary.icp.BriefReport();
  EXPECT_LT(levels.front().threshold_end_mm, levels.front().threshold_start_mm);
  for (size_t l = 1; l < levels.size(); ++l) {
    EXPECT_LE(levels[l].threshold_start_mm, levels[l - 1].threshold_end_mm + 1e-12);
  }
  EXPECT_LT(levels.back().rms_end_mm, 0.5);
}

TEST(RegisterViews, BadViewsAreReportedAndGoodViewsKept) {
  const Fixture& f = Views();
  std::vector<RegistrationView> views = f.views;
  RegistrationView empty;
  empty.name = "empty";
  RegistrationView metres = f.views[1];
  metres.name = "metres";
  for (auto& p : metres.cloud.points) p *= 1e-3;
  metres.markers.clear();
  RegistrationView no_normals = f.views[3];
  no_normals.name = "no_normals";
  no_normals.cloud.normals.clear();
  // Noise far from everything: no markers, nothing to overlap.
  RegistrationView stray;
  stray.name = "stray";
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-30, 30);
  for (int k = 0; k < 3000; ++k) {
    stray.cloud.points.emplace_back(u(rng), u(rng), 900 + u(rng));
    stray.cloud.normals.push_back(Eigen::Vector3d(u(rng), u(rng), -30).normalized());
  }
  views.push_back(empty);
  views.push_back(metres);
  views.push_back(no_normals);
  views.push_back(stray);
  const RegistrationResult r = RegisterViews(views);
  EXPECT_EQ(r.summary.status, RegistrationStatus::kPartial);
  EXPECT_EQ(r.summary.placed, 4);
  EXPECT_EQ(r.views[4].path, ViewPath::kBadInput);
  EXPECT_NE(r.views[4].message.find("empty"), std::string::npos);
  EXPECT_EQ(r.views[5].path, ViewPath::kBadInput);
  EXPECT_NE(r.views[5].message.find("metres"), std::string::npos);
  EXPECT_EQ(r.views[6].path, ViewPath::kBadInput);
  EXPECT_NE(r.views[6].message.find("normals"), std::string::npos);
  EXPECT_EQ(r.views[7].path, ViewPath::kUnplaced) << r.views[7].message;
  EXPECT_FALSE(r.views[7].message.empty());
  for (int v = 1; v < 4; ++v) {
    EXPECT_LT(PoseError(f, Poses(r), v).angle_rad * 180 / M_PI, kRotTolDeg);
  }
}

// Bad input: an unorganized cloud without normals gets them estimated (and says so), oriented
// toward the sensor; a cloud in metres read with --units m comes back in millimetres.
constexpr double kEstimatedNormalTolDeg = 3;  // 20-neighbour PCA on a 1 mm grid, no noise

TEST(ReadRegistrationView, MissingNormalsAreEstimatedTowardTheSensorAndReported) {
  test::TempDir dir;
  PointCloud c;  // a gently curved sheet 300 mm in front of the sensor, facing it
  for (double x = -40; x <= 40; x += 1) {
    for (double y = -30; y <= 30; y += 1) {
      c.points.emplace_back(x, y, 300 + 0.002 * x * x);
    }
  }
  io::WritePly(dir / "sheet.ply", c);
  std::string note;
  const RegistrationView v = ReadRegistrationView(dir / "sheet.ply", 1.0, false, &note);
  EXPECT_NE(note.find("normals estimated"), std::string::npos) << note;
  ASSERT_EQ(v.cloud.normals.size(), v.cloud.size());
  for (size_t i = 0; i < v.cloud.size(); i += 97) {
    const Eigen::Vector3d& p = v.cloud.points[i];
    const Eigen::Vector3d truth = Eigen::Vector3d(0.004 * p.x(), 0, -1).normalized();
    EXPECT_LT(std::acos(std::min(1.0, v.cloud.normals[i].dot(truth))) * 180 / M_PI,
              kEstimatedNormalTolDeg)
        << "point " << i;
  }
  // The same sheet written in metres and read with scale 1000 is the millimetre sheet.
  PointCloud m = c;
  for (auto& p : m.points) p *= 1e-3;
  io::WritePly(dir / "sheet_m.ply", m);
  const RegistrationView vm = ReadRegistrationView(dir / "sheet_m.ply", 1000.0, false, nullptr);
  ASSERT_EQ(vm.cloud.size(), c.size());
  EXPECT_LT((vm.cloud.points[5] - c.points[5]).norm(), 1e-3);
}

}  // namespace
}  // namespace fringe::registration
