#include "fringe/registration/markers.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "fringe/testing/registration_views.h"
#include "fringe/util/error.h"

namespace fringe::registration {
namespace {

using testing::MakeMarker;
using testing::SimulateView;
using testing::SmallRig;

// On the quarter-resolution rig a pixel is ~0.8 mm on the part; the ring fits locate centres to
// a few hundredths of a pixel at σ = 1.5 DN.
constexpr double kCentreTolPx = 0.1;
constexpr double kCentreTolMm = 0.25;  // triangulated centre vs truth (depth dominates)
constexpr double kNormalTolDeg = 3.0;  // fitted surface plane vs true normal
// RMS centre error over RMS predicted sigma (see MatchesTruthOnPlaneAndBox).
constexpr double kMinSigmaRatio = 0.6;
constexpr double kMaxSigmaRatio = 1.6;

const sim::MarkerObservation* NearestTruth(const std::vector<sim::MarkerObservation>& truth,
                                           const Eigen::Vector2d& left_px, double max_px) {
  const sim::MarkerObservation* best = nullptr;
  double best_d = max_px;
  for (const auto& t : truth) {
    const double d = (t.left_px - left_px).norm();
    if (d < best_d) {
      best_d = d;
      best = &t;
    }
  }
  return best;
}

TEST(MarkerDetectionOptions, DefaultsPassCheck) {
  EXPECT_NO_THROW(MarkerDetectionOptions().Check());
}

TEST(MarkerDetectionOptions, CheckNamesTheField) {
  MarkerDetectionOptions o;
  o.max_outer_radius_mm = 0.5;
  try {
    o.Check();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("max_outer_radius_mm"), std::string::npos);
  }
}

TEST(DetectViewMarkers, MatchesTruthOnPlaneAndBox) {
  const StereoRig rig = SmallRig();
  sim::Scene scene = testing::PlaneWithBox();
  // A dark spot without a white centre: a blob that is not a marker.
  scene.AddObject([] {
    sim::SceneObject spot;
    spot.name = "spot";
    spot.mesh = sim::MakeRectangleMesh({-70, -55, 0.01}, Eigen::Vector3d::UnitX(),
                                       Eigen::Vector3d::UnitY(), 20, 20);
    spot.texture = [](const Eigen::Vector3d& p) {
      return (p.head<2>() - Eigen::Vector2d(-70, -55)).norm() < 5 ? 0.03 : 0.6;
    };
    return spot;
  }());
  int id = 0;
  for (double x : {-80.0, -45.0, 45.0, 80.0}) {
    for (double y : {-55.0, 0.0, 55.0}) {
      if (x == -80.0 && y == -55.0) continue;  // the dark spot's place
      scene.AddMarker(MakeMarker(id++, {x, y, 0}));
    }
  }
  scene.AddMarker(MakeMarker(id++, {-15, -15, 25}));
  scene.AddMarker(MakeMarker(id++, {15, 12, 25}));
  const Rigid3d world_from_sensor = sim::SensorPoseLookingAt(
      rig, Eigen::Vector3d(0, 0, 10), Eigen::Vector3d(0.15, -0.3, 1).normalized(), 0.2);
  const testing::SimulatedView view = SimulateView(rig, scene, world_from_sensor);
  ASSERT_TRUE(view.rec.summary.ok()) << view.rec.summary.BriefReport();
  const ViewMarkers vm =
      DetectViewMarkers(rig, view.rec.texture_left, view.rec.texture_right, view.rec.cloud);
  ASSERT_TRUE(vm.summary.ok()) << vm.summary.BriefReport();

  int visible_both = 0;
  for (const auto& t : view.truth_markers) visible_both += t.visible_left && t.visible_right;
  ASSERT_GE(visible_both, 10) << "the view should see most markers";
  EXPECT_GE(vm.summary.markers, visible_both - 1) << vm.summary.BriefReport();

  const Rigid3d sensor_from_world = world_from_sensor.Inverse();
  double ss_error = 0, ss_sigma = 0;  // centre errors against truth and predicted sigmas, mm^2
  for (const ViewMarker& m : vm.markers) {
    const sim::MarkerObservation* t = NearestTruth(view.truth_markers, m.left_px, 3.0);
    ASSERT_NE(t, nullptr) << "marker at " << m.left_px.transpose() << " is not a true marker";
    EXPECT_LT((m.left_px - t->left_px).norm(), kCentreTolPx) << "marker " << t->id;
    // The right centre belongs to the same marker: the stereo match is correct.
    EXPECT_LT((m.right_px - t->right_px).norm(), kCentreTolPx) << "marker " << t->id;
    EXPECT_LT((m.centre_in_sensor - t->centre_in_sensor).norm(), kCentreTolMm)
        << "marker " << t->id;
    const Eigen::Vector3d n_true =
        sensor_from_world.RotateDirection(scene.markers()[t->id].normal_in_world);
    EXPECT_LT(std::acos(std::clamp(m.normal_in_sensor.dot(n_true), -1.0, 1.0)) * 180 / M_PI,
              kNormalTolDeg)
        << "marker " << t->id;
    EXPECT_NEAR(m.outer_radius_mm, 5.0, 0.5);
    EXPECT_GT(m.sigma_mm, 0);
    EXPECT_LT(m.sigma_mm, 1.0);
    // The covariance is the one sigma_mm summarises, and triangulation is least certain along
    // the viewing ray: its largest axis lies within 20 deg of the ray.
    EXPECT_NEAR(std::sqrt(m.covariance_mm2.trace()), m.sigma_mm, 1e-12);
    ss_error += (m.centre_in_sensor - t->centre_in_sensor).squaredNorm();
    ss_sigma += m.sigma_mm * m.sigma_mm;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(m.covariance_mm2);
    const double along_ray =
        std::abs(eig.eigenvectors().col(2).dot(m.centre_in_sensor.normalized()));
    EXPECT_GT(along_ray, std::cos(20 * M_PI / 180)) << "marker " << t->id;
    EXPECT_GT(eig.eigenvalues()(2), 2 * eig.eigenvalues()(1)) << "marker " << t->id;
  }
  // The predicted sigmas are the centres' actual scatter in absolute scale: RMS error over RMS
  // sigma near 1 (about a dozen markers: +-30 % from the sample alone; the model before, one
  // circle fitted to both ellipses' edge points, was ~2.2).
  const double sigma_ratio = std::sqrt(ss_error / ss_sigma);
  EXPECT_GT(sigma_ratio, kMinSigmaRatio);
  EXPECT_LT(sigma_ratio, kMaxSigmaRatio);
  // The dark spot was seen as a blob and rejected with a reason.
  const Eigen::Vector2d spot_px =
      rig.left.Project(sensor_from_world * Eigen::Vector3d(-70, -55, 0.01));
  bool spot_rejected = false;
  for (const auto& r : vm.summary.rejected) {
    if ((r.left_px - spot_px).norm() < 4 && !r.reason.empty()) spot_rejected = true;
  }
  EXPECT_TRUE(spot_rejected);
  for (const ViewMarker& m : vm.markers) EXPECT_GT((m.left_px - spot_px).norm(), 4);
}

// Two markers on one epipolar line: the epipolar constraint offers each left ring both right
// rings; only the depth-difference test tells them apart.
TEST(DetectViewMarkers, DepthDifferenceResolvesTwoMarkersOnOneEpipolarLine) {
  const StereoRig rig = SmallRig();
  sim::Scene scene;
  sim::SceneObject plane;
  plane.name = "plane";
  plane.mesh = sim::MakeRectangleMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                      Eigen::Vector3d::UnitY(), 400, 400);
  scene.AddObject(plane);
  scene.AddMarker(MakeMarker(0, {-30, 0, 0}));
  scene.AddMarker(MakeMarker(1, {30, 0, 0}));
  // Looking straight down: world x runs along the image rows, so both markers share a row.
  const Rigid3d world_from_sensor =
      sim::SensorPoseLookingAt(rig, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  const testing::SimulatedView view = SimulateView(rig, scene, world_from_sensor);
  ASSERT_TRUE(view.rec.summary.ok());
  ASSERT_EQ(view.truth_markers.size(), 2u);
  const auto& a = view.truth_markers[0];
  const auto& b = view.truth_markers[1];
  ASSERT_TRUE(a.visible_left && a.visible_right && b.visible_left && b.visible_right);
  MarkerDetectionOptions options;
  // Both crossings are candidates by the epipolar constraint alone.
  ASSERT_LT(EpipolarDistancePx(rig, a.left_px, b.right_px), options.max_epipolar_px);
  ASSERT_LT(EpipolarDistancePx(rig, b.left_px, a.right_px), options.max_epipolar_px);

  const ViewMarkers vm = DetectViewMarkers(rig, view.rec.texture_left, view.rec.texture_right,
                                           view.rec.cloud, options);
  ASSERT_EQ(vm.markers.size(), 2u) << vm.summary.BriefReport();
  EXPECT_EQ(vm.summary.ambiguous_resolved, 2);
  for (const ViewMarker& m : vm.markers) {
    const sim::MarkerObservation* t = NearestTruth(view.truth_markers, m.left_px, 3.0);
    ASSERT_NE(t, nullptr);
    EXPECT_LT((m.right_px - t->right_px).norm(), kCentreTolPx);
    EXPECT_LT((m.centre_in_sensor - t->centre_in_sensor).norm(), kCentreTolMm);
  }
}

// One camera + projector: the markers come from the left image alone, each centre where the
// camera ray through the ring centre meets the camera-projector surface.
TEST(DetectViewMarkersOneCamera, MatchesTruthOnPlaneAndBox) {
  const StereoRig rig = SmallRig();
  sim::Scene scene = testing::PlaneWithBox();
  int id = 0;
  for (double x : {-80.0, -45.0, 45.0, 80.0}) {
    for (double y : {-55.0, 0.0, 55.0}) scene.AddMarker(MakeMarker(id++, {x, y, 0}));
  }
  scene.AddMarker(MakeMarker(id++, {-15, -15, 25}));
  const Rigid3d world_from_sensor = sim::SensorPoseLookingAt(
      rig, Eigen::Vector3d(0, 0, 10), Eigen::Vector3d(0.15, -0.3, 1).normalized(), 0.2);
  const testing::SimulatedView view = SimulateView(rig, scene, world_from_sensor, 0, true);
  const stereo::ViewReconstruction& rec = view.rec_camera_projector;
  ASSERT_TRUE(rec.summary.ok()) << rec.summary.BriefReport();
  EXPECT_THROW(DetectViewMarkersOneCamera(rig.left, rec.texture_left, OrganizedPointCloud(4, 4)),
               Error);
  const ViewMarkers vm = DetectViewMarkersOneCamera(rig.left, rec.texture_left, rec.cloud);
  ASSERT_TRUE(vm.summary.ok()) << vm.summary.BriefReport();
  int visible_left = 0;
  for (const auto& t : view.truth_markers) visible_left += t.visible_left;
  ASSERT_GE(visible_left, 10);
  EXPECT_GE(vm.summary.markers, visible_left - 1) << vm.summary.BriefReport();
  const Rigid3d sensor_from_world = world_from_sensor.Inverse();
  double worst_mm = 0;
  for (const ViewMarker& m : vm.markers) {
    const sim::MarkerObservation* t = NearestTruth(view.truth_markers, m.left_px, 3.0);
    ASSERT_NE(t, nullptr) << "marker at " << m.left_px.transpose() << " is not a true marker";
    EXPECT_LT((m.left_px - t->left_px).norm(), kCentreTolPx) << "marker " << t->id;
    EXPECT_FALSE(m.right_px.allFinite());  // no second image
    const double e = (m.centre_in_sensor - t->centre_in_sensor).norm();
    worst_mm = std::max(worst_mm, e);
    EXPECT_LT(e, kCentreTolMm) << "marker " << t->id;
    const Eigen::Vector3d n_true =
        sensor_from_world.RotateDirection(scene.markers()[t->id].normal_in_world);
    EXPECT_LT(std::acos(std::clamp(m.normal_in_sensor.dot(n_true), -1.0, 1.0)) * 180 / M_PI,
              kNormalTolDeg);
    EXPECT_NEAR(m.outer_radius_mm, 5.0, 0.5);
    EXPECT_GT(m.sigma_mm, 0);
    EXPECT_LT(m.sigma_mm, 1.0);
  }
  std::cout << vm.markers.size() << " markers, worst centre error " << worst_mm << " mm\n";
  // The file keeps the missing right image as null and reads it back.
  const auto path = std::filesystem::temp_directory_path() / "fringe_markers_one_camera.json";
  WriteViewMarkers(path, vm.markers);
  const std::vector<ViewMarker> back = ReadViewMarkers(path);
  ASSERT_EQ(back.size(), vm.markers.size());
  EXPECT_FALSE(back[0].right_px.allFinite());
  std::filesystem::remove(path);
}

TEST(ViewMarkersFile, RoundTrip) {
  ViewMarker m;
  m.id = 3;
  m.centre_in_sensor = {1.5, -2.25, 480.125};
  m.normal_in_sensor = Eigen::Vector3d(0.1, 0.2, -1).normalized();
  m.left_px = {100.25, 80.5};
  m.right_px = {90.75, 81.0};
  m.outer_radius_mm = 2.5;
  m.sigma_mm = 0.02;
  m.depth_difference_mm = -0.05;
  m.covariance_mm2 << 4e-5, 1e-6, 2e-6, 1e-6, 5e-5, -3e-6, 2e-6, -3e-6, 3e-4;
  ViewMarker old = m;  // a file from before the covariance: sigma_mm stands for it
  old.covariance_mm2.setZero();
  const auto path =
      std::filesystem::temp_directory_path() / "fringe_markers_roundtrip.markers.json";
  WriteViewMarkers(path, {m, old});
  const std::vector<ViewMarker> back = ReadViewMarkers(path);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_LT((back[0].covariance_mm2 - m.covariance_mm2).norm(), 1e-15);
  EXPECT_TRUE(back[1].covariance_mm2.isZero(0));
  EXPECT_LT((CentreCovariance(back[1]) - Eigen::Matrix3d::Identity() * 0.02 * 0.02 / 3).norm(),
            1e-15);
  EXPECT_LT((CentreCovariance(back[0]) - m.covariance_mm2).norm(), 1e-15);
  EXPECT_EQ(back[0].id, 3);
  EXPECT_LT((back[0].centre_in_sensor - m.centre_in_sensor).norm(), 1e-9);
  EXPECT_LT((back[0].normal_in_sensor - m.normal_in_sensor).norm(), 1e-9);
  EXPECT_LT((back[0].right_px - m.right_px).norm(), 1e-9);
  EXPECT_DOUBLE_EQ(back[0].sigma_mm, m.sigma_mm);
  std::filesystem::remove(path);
}

TEST(ViewMarkersFile, MalformedFilesNameTheProblem) {
  const auto path = std::filesystem::temp_directory_path() / "fringe_markers_bad.markers.json";
  auto expect_error = [&](const std::string& text, const std::string& what) {
    std::ofstream(path) << text;
    try {
      ReadViewMarkers(path);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(path.string()), std::string::npos) << msg;
      EXPECT_NE(msg.find(what), std::string::npos) << msg;
    }
  };
  expect_error("{\"format\": \"fringe-poses\", \"markers\": []}", "format");
  expect_error("{\"markers\": 3}", "markers");
  expect_error(
      "{\"markers\": [{\"id\": 0, \"centre_in_sensor\": [0, 0, 500], \"normal_in_sensor\": [0, "
      "0, 2], \"left_px\": [1, 2], \"right_px\": [1, 2], \"outer_radius_mm\": 2.5, "
      "\"sigma_mm\": 0.1}]}",
      "normal_in_sensor");
  expect_error(
      "{\"markers\": [{\"id\": 0, \"centre_in_sensor\": [0, 0, 500], \"normal_in_sensor\": [0, "
      "0, -1], \"left_px\": [1, 2], \"right_px\": [1, 2], \"outer_radius_mm\": 2.5, "
      "\"sigma_mm\": -1}]}",
      "sigma_mm");
  expect_error(
      "{\"markers\": [{\"id\": 0, \"centre_in_sensor\": [0, 0, 500], \"normal_in_sensor\": [0, "
      "0, -1], \"left_px\": [1, 2], \"right_px\": [1, 2], \"outer_radius_mm\": 2.5, "
      "\"sigma_mm\": 0.1, \"covariance_mm2\": [1, 0, 0, -1, 0, 1]}]}",
      "covariance_mm2");
  expect_error(
      "{\"markers\": [{\"id\": 0, \"centre_in_sensor\": [0, 0, 500], \"normal_in_sensor\": [0, "
      "0, -1], \"left_px\": [1, 2], \"right_px\": [1, 2], \"outer_radius_mm\": 2.5, "
      "\"sigma_mm\": 0.1, \"covariance_mm2\": [1e300, 0, 0, 1e300, 0, 1e300]}]}",
      "covariance_mm2");
  expect_error("{\"markers\": [", "invalid JSON");
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace fringe::registration
