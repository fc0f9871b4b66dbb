#include "fringe/stereo/camera_projector.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scene.h"
#include "fringe/util/error.h"

namespace fringe::stereo {
namespace {

// The reference rig's left camera and projector, the projector with a strong lens distortion
// (so that ignoring it would be visible).
CameraProjectorRig DistortedRig(double scale = 1.0) {
  StereoRig rig = sim::ScaledRig(StereoRig::Reference(), scale);
  rig.projector->k1 = -0.12;
  rig.projector->k2 = 0.08;
  rig.projector->p1 = 1.5e-3;
  rig.projector->p2 = -8e-4;
  rig.projector->k3 = 0.02;
  return CameraProjectorRig::FromLeftCamera(rig);
}

struct ExactCorrespondence {
  Eigen::Vector3d p_in_camera;
  Eigen::Vector2d camera_px, projector_px;
};

// Random points in the measuring volume seen by the camera and lit by the projector.
std::vector<ExactCorrespondence> ExactCorrespondences(const CameraProjectorRig& rig, int count) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0, 1), z(380, 650);
  std::vector<ExactCorrespondence> out;
  while (static_cast<int>(out.size()) < count) {
    const Eigen::Vector2d px(u(rng) * (rig.camera.width - 1), u(rng) * (rig.camera.height - 1));
    ExactCorrespondence c;
    c.p_in_camera = rig.camera.Ray(px) * z(rng);
    c.camera_px = rig.camera.Project(c.p_in_camera);
    c.projector_px = rig.projector.Project(rig.projector_from_camera * c.p_in_camera);
    if (!rig.projector.InImage(c.projector_px)) continue;
    out.push_back(c);
  }
  return out;
}

// Exact correspondences give back the true points, with the projector's distortion, for a
// column (vertical fringes), a row (horizontal fringes) and both.
TEST(CameraProjector, TriangulationRoundTripIsExact) {
  constexpr double kTolMm = 1e-6;
  constexpr double kRoundTripTolPx = 1e-9;
  const CameraProjectorRig rig = DistortedRig();
  double worst_u = 0, worst_v = 0, worst_uv = 0;
  for (const auto& c : ExactCorrespondences(rig, 500)) {
    const auto tu = TriangulateCameraProjector(rig, c.camera_px, c.projector_px.x(),
                                               phase::FringeDirection::kVertical);
    ASSERT_TRUE(tu.ok()) << ToString(tu.status);
    worst_u = std::max(worst_u, (tu.p_in_left - c.p_in_camera).norm());
    EXPECT_LT(tu.reprojection_error_px, kRoundTripTolPx);
    const auto tv = TriangulateCameraProjector(rig, c.camera_px, c.projector_px.y(),
                                               phase::FringeDirection::kHorizontal);
    ASSERT_TRUE(tv.ok()) << ToString(tv.status);
    worst_v = std::max(worst_v, (tv.p_in_left - c.p_in_camera).norm());
    const auto tuv = TriangulateCameraProjector(rig, c.camera_px, c.projector_px);
    ASSERT_TRUE(tuv.ok()) << ToString(tuv.status);
    worst_uv = std::max(worst_uv, (tuv.p_in_left - c.p_in_camera).norm());
  }
  std::cout << "worst error: column " << worst_u << " mm, row " << worst_v << " mm, both "
            << worst_uv << " mm\n";
  EXPECT_LT(worst_u, kTolMm);
  EXPECT_LT(worst_v, kTolMm);
  EXPECT_LT(worst_uv, kTolMm);
}

// The distortion matters: the plane through the column of a pinhole projector misses the
// points by far more than the tolerance above.
TEST(CameraProjector, IgnoringProjectorDistortionIsVisible) {
  constexpr double kMinEffectMm = 0.1;
  const CameraProjectorRig rig = DistortedRig();
  CameraProjectorRig pinhole = rig;
  pinhole.projector.SetDistortion({0, 0, 0, 0, 0});
  double worst = 0;
  for (const auto& c : ExactCorrespondences(rig, 100)) {
    const auto t = TriangulateCameraProjector(pinhole, c.camera_px, c.projector_px.x(),
                                              phase::FringeDirection::kVertical);
    if (t.ok()) worst = std::max(worst, (t.p_in_left - c.p_in_camera).norm());
  }
  EXPECT_GT(worst, kMinEffectMm);
}

TEST(CameraProjector, DegenerateGeometry) {
  const CameraProjectorRig rig = DistortedRig();
  // A ray pointing away from the projector's field: the column surface lies behind the camera.
  const Eigen::Vector3d backwards = Eigen::Vector3d(0, 0, -1);
  const auto t =
      TriangulateCameraProjectorRay(rig, backwards, 640, phase::FringeDirection::kVertical);
  EXPECT_FALSE(t.ok());
  StereoRig no_projector = StereoRig::Reference();
  no_projector.projector.reset();
  EXPECT_THROW(CameraProjectorRig::FromLeftCamera(no_projector), Error);
  CameraProjectorRig zero = rig;
  zero.projector_from_camera = Rigid3d();
  EXPECT_THROW(zero.Check(), Error);
}

// The reference rig at a quarter of its resolution, the projector distorted; renders of the
// simulator (sigma 1.5 DN) reconstructed in camera-projector mode against the true surface.
struct Simulated {
  StereoRig rig;
  CameraProjectorRig cp;
  Simulated() {
    rig = sim::ScaledRig(StereoRig::Reference(), 0.25);
    rig.projector->k1 = -0.12;
    rig.projector->k2 = 0.08;
    rig.projector->p1 = 1.5e-3;
    cp = CameraProjectorRig::FromLeftCamera(rig);
  }
  sim::ViewImages Render(const sim::Scene& scene, const Rigid3d& world_from_sensor,
                         const phase::PatternScheme& scheme) const {
    sim::RenderOptions options;
    options.projector.gamma = 1.0;
    const sim::Renderer renderer(scene, rig, options);
    return renderer.RenderView(world_from_sensor, phase::GeneratePatterns(scheme));
  }
};

struct Deviation {
  int lit = 0, points = 0, compared = 0;
  double rms_mm = 0, max_mm = 0;
};

// True when the pixel and its 8 neighbours are lit and on the same scene object: the pixel's
// footprint (the renderer supersamples it) lies on one surface, so its true point at the pixel
// centre is what it measures. Pixels straddling an object's edge or a shadow boundary mix two
// surfaces' phases; with one camera there is no second view to reject them, and they are
// counted separately (Deviation::points).
bool Interior(const sim::CameraTruth& t, int r, int c) {
  if (r < 1 || c < 1 || r + 1 >= t.valid.rows || c + 1 >= t.valid.cols) return false;
  const int id = t.object_id.at<int>(r, c);
  for (int dr = -1; dr <= 1; ++dr) {
    for (int dc = -1; dc <= 1; ++dc) {
      if (!t.valid.at<uint8_t>(r + dr, c + dc) || t.object_id.at<int>(r + dr, c + dc) != id) {
        return false;
      }
    }
  }
  return true;
}

// Deviation from the true surface over the interior lit pixels (Interior above).
Deviation Compare(const sim::CameraTruth& t, const ViewReconstruction& rec) {
  Deviation d;
  double ss = 0;
  for (int r = 0; r < rec.cloud.height; ++r) {
    for (int c = 0; c < rec.cloud.width; ++c) {
      const size_t i = rec.cloud.index(c, r);
      d.points += rec.cloud.valid[i];
      if (!Interior(t, r, c)) continue;
      ++d.lit;
      if (!rec.cloud.valid[i]) continue;
      const cv::Vec3d tp = t.points.at<cv::Vec3d>(r, c);
      const double e = (rec.cloud.cloud.points[i] - Eigen::Vector3d(tp[0], tp[1], tp[2])).norm();
      ss += e * e;
      d.max_mm = std::max(d.max_mm, e);
      ++d.compared;
    }
  }
  d.rms_mm = d.compared ? std::sqrt(ss / d.compared) : 0;
  return d;
}

// Sphere on a plate, vertical fringes: one camera reconstructs it; and the horizontal-fringe
// chain end to end (patterns -> render -> decode -> row triangulation), and both directions.
TEST(CameraProjector, SimulatedSphereAllDirections) {
  // The camera-projector baseline (~102 mm) is half the stereo one (200 mm), so depth noise is
  // about twice stereo's 0.1 mm bound on this scene at this scale (measured: 0.097 mm columns,
  // 0.096 mm both directions, 0.52 mm rows).
  constexpr double kRmsTolMm = 0.15;
  constexpr double kRowRmsTolMm = 0.6;  // rows: only the 20 mm vertical offset triangulates
  constexpr double kMaxTolMm = 1.0;
  constexpr double kMinCoverage = 0.9;  // of the lit camera pixels
  const Simulated s;
  const sim::Scene scene = sim::MakeSphereScene(25.0);
  const Rigid3d pose = sim::SensorPoseLookingAt(s.rig, Eigen::Vector3d(0, 0, 25),
                                                Eigen::Vector3d(0, -0.5, 1).normalized());
  phase::PatternScheme vertical =
      phase::MakeScheme("heterodyne-4x3", s.rig.projector->width, s.rig.projector->height);
  phase::PatternScheme horizontal = vertical;
  horizontal.direction = phase::FringeDirection::kHorizontal;
  horizontal.name += "-horizontal";
  const sim::ViewImages vv = s.Render(scene, pose, vertical);
  const sim::ViewImages vh = s.Render(scene, pose, horizontal);

  const ViewReconstructor column = MakeCameraProjectorReconstructor(s.cp, {vertical});
  const ViewReconstruction rc = column.Reconstruct({{vv.left.images}, {}});
  SCOPED_TRACE(rc.summary.BriefReport());
  ASSERT_TRUE(rc.summary.ok());
  const Deviation dc = Compare(vv.left.truth, rc);
  std::cout << "column: " << dc.compared << " of " << dc.lit << " lit, RMS " << dc.rms_mm
            << " mm, max " << dc.max_mm << " mm; " << rc.summary.BriefReport() << "\n";
  EXPECT_GT(dc.compared, kMinCoverage * dc.lit);
  EXPECT_LT(dc.rms_mm, kRmsTolMm);
  EXPECT_LT(dc.max_mm, kMaxTolMm);
  EXPECT_LT(rc.summary.matching.mean_reprojection_error_px, 1e-6);  // the round trip

  const ViewReconstructor row = MakeCameraProjectorReconstructor(s.cp, {horizontal});
  const ViewReconstruction rr = row.Reconstruct({{vh.left.images}, {}});
  ASSERT_TRUE(rr.summary.ok()) << rr.summary.BriefReport();
  const Deviation dr = Compare(vh.left.truth, rr);
  std::cout << "row: " << dr.compared << " of " << dr.lit << " lit, RMS " << dr.rms_mm << " mm\n";
  EXPECT_GT(dr.compared, kMinCoverage * dr.lit);
  EXPECT_LT(dr.rms_mm, kRowRmsTolMm);

  // Both directions: the order of the schemes does not matter.
  const ViewReconstructor both = MakeCameraProjectorReconstructor(s.cp, {horizontal, vertical});
  const ViewReconstruction rb = both.Reconstruct({{vh.left.images, vv.left.images}, {}});
  ASSERT_TRUE(rb.summary.ok()) << rb.summary.BriefReport();
  const Deviation db = Compare(vv.left.truth, rb);
  std::cout << "both: " << db.compared << " of " << db.lit << " lit, RMS " << db.rms_mm << " mm\n";
  EXPECT_GT(db.compared, kMinCoverage * db.lit);
  EXPECT_LT(db.rms_mm, kRmsTolMm);
}

TEST(CameraProjector, RejectsBadSchemesAndSizes) {
  const Simulated s;
  const phase::PatternScheme vertical =
      phase::MakeScheme("heterodyne-4x3", s.rig.projector->width, s.rig.projector->height);
  EXPECT_THROW(MakeCameraProjectorReconstructor(s.cp, {}), Error);
  EXPECT_THROW(MakeCameraProjectorReconstructor(s.cp, {vertical, vertical}), Error);
  const ViewReconstructor rec = MakeCameraProjectorReconstructor(s.cp, {vertical});
  const std::vector<cv::Mat> small(vertical.NumImages(), cv::Mat(10, 10, CV_8UC1));
  EXPECT_THROW(rec.Reconstruct({{small}, {}}), Error);
  EXPECT_THROW(rec.Reconstruct(ViewStacks{}), Error);
  const std::vector<cv::Mat> dark(
      vertical.NumImages(), cv::Mat(s.cp.camera.height, s.cp.camera.width, CV_8UC1, cv::Scalar(0)));
  const ViewReconstruction r = rec.Reconstruct({{dark}, {}});
  EXPECT_EQ(r.summary.status, ReconstructionStatus::kNoValidPixels);
}

// A tilted plane in camera-projector mode: noise-limited and unbiased (a wrong pixel-centre or
// phase convention between the decoder and the projector model would show as a mean offset).
TEST(CameraProjector, SimulatedPlaneIsUnbiased) {
  constexpr double kRmsTolMm = 0.15;  // measured 0.08: half the stereo baseline, see below
  constexpr double kMeanTolMm = 0.02;
  constexpr double kMinCoverage = 0.95;
  const Simulated s;
  const sim::Scene scene = sim::MakePlaneScene();
  const Rigid3d pose = sim::SensorPoseLookingAt(s.rig, Eigen::Vector3d::Zero(),
                                                Eigen::Vector3d(0.3, 0.2, 1).normalized());
  const phase::PatternScheme vertical =
      phase::MakeScheme("heterodyne-4x3", s.rig.projector->width, s.rig.projector->height);
  const sim::ViewImages view = s.Render(scene, pose, vertical);
  const ViewReconstruction rec =
      MakeCameraProjectorReconstructor(s.cp, {vertical}).Reconstruct({{view.left.images}, {}});
  ASSERT_TRUE(rec.summary.ok()) << rec.summary.BriefReport();
  const Deviation d = Compare(view.left.truth, rec);
  double sum_dz = 0;
  for (int r = 0; r < rec.cloud.height; ++r) {
    for (int c = 0; c < rec.cloud.width; ++c) {
      const size_t i = rec.cloud.index(c, r);
      if (!rec.cloud.valid[i] || !Interior(view.left.truth, r, c)) continue;
      sum_dz += rec.cloud.cloud.points[i].z() - view.left.truth.points.at<cv::Vec3d>(r, c)[2];
    }
  }
  const double mean_dz = d.compared ? sum_dz / d.compared : 0;
  std::cout << "plane: " << d.compared << " of " << d.lit << " lit, RMS " << d.rms_mm << " mm, max "
            << d.max_mm << " mm, mean depth error " << mean_dz << " mm\n";
  EXPECT_GT(d.compared, kMinCoverage * d.lit);
  EXPECT_LT(d.rms_mm, kRmsTolMm);
  EXPECT_LT(std::abs(mean_dz), kMeanTolMm);
  // Every kept point carries what fusion weighs by (as in stereo mode).
  const PointCloud& pc = rec.cloud.cloud;
  ASSERT_TRUE(pc.has_quality() && pc.has_intensity() && pc.has_residual());
  for (size_t i = 0; i < rec.cloud.valid.size(); ++i) {
    if (!rec.cloud.valid[i]) continue;
    ASSERT_EQ(pc.residual_px[i],
              rec.reprojection_error_px.at<float>(static_cast<int>(i) / rec.cloud.width,
                                                  static_cast<int>(i) % rec.cloud.width));
    ASSERT_GT(pc.quality[i], 0.f);
  }
  EXPECT_FALSE(rec.texture_left.empty());
}

// Trinocular use of the stereo rig with its projector: the plate behind the sphere that only
// the left camera sees (the sphere hides it from the right camera) is filled from the left
// camera + projector; every stereo point is kept as it was, and the added points are as accurate
// as camera-projector mode.
TEST(CameraProjector, TrinocularFillsLeftOnlyPixels) {
  constexpr double kMinGain = 0.005;  // of the interior lit left pixels (measured 0.0104)
  constexpr double kRmsTolMm = 0.15;  // camera-projector bound of the sphere test above
  constexpr double kFarOffMm = 0.5;
  constexpr double kMaxFarOffFraction = 0.02;  // measured: 2 of ~400
  const Simulated s;
  const sim::Scene scene = sim::MakeSphereScene(25.0);
  const Rigid3d pose = sim::SensorPoseLookingAt(s.rig, Eigen::Vector3d(0, 0, 25),
                                                Eigen::Vector3d(0, -0.5, 1).normalized());
  const phase::PatternScheme vertical =
      phase::MakeScheme("heterodyne-4x3", s.rig.projector->width, s.rig.projector->height);
  const sim::ViewImages view = s.Render(scene, pose, vertical);
  const ReconstructionOptions options;
  const ViewReconstruction stereo =
      ViewReconstructor(s.rig, vertical, options).Reconstruct(view.left.images, view.right.images);
  const ViewReconstructor trinocular(MakeTrinocularCorrespondence(s.rig, options.matching),
                                     {vertical}, options);
  EXPECT_STREQ(trinocular.correspondence().Name(), "trinocular");
  const ViewReconstruction tri = trinocular.Reconstruct(view.left.images, view.right.images);
  ASSERT_TRUE(stereo.summary.ok()) << stereo.summary.BriefReport();
  ASSERT_TRUE(tri.summary.ok()) << tri.summary.BriefReport();
  const Deviation ds = Compare(view.left.truth, stereo);
  const Deviation dt = Compare(view.left.truth, tri);
  const double gain = static_cast<double>(dt.compared - ds.compared) / dt.lit;
  std::cout << "stereo: " << ds.compared << " of " << ds.lit << " lit, RMS " << ds.rms_mm
            << " mm; trinocular: " << dt.compared << ", RMS " << dt.rms_mm << " mm, max "
            << dt.max_mm << " mm, gain " << gain << ", " << tri.summary.matching.projector_filled
            << " filled\n";
  EXPECT_GT(tri.summary.matching.projector_filled, 0);
  EXPECT_GT(gain, kMinGain);
  EXPECT_LT(dt.rms_mm, kRmsTolMm);
  // The added points alone: as accurate as camera-projector mode, few far off (the sphere's
  // limb, where the left camera sees it at grazing incidence).
  int added = 0, far_off = 0;
  double ss = 0;
  for (int r = 0; r < tri.cloud.height; ++r) {
    for (int c = 0; c < tri.cloud.width; ++c) {
      const size_t i = tri.cloud.index(c, r);
      if (!tri.cloud.valid[i] || stereo.cloud.valid[i] || !Interior(view.left.truth, r, c)) {
        continue;
      }
      const cv::Vec3d tp = view.left.truth.points.at<cv::Vec3d>(r, c);
      const double e = (tri.cloud.cloud.points[i] - Eigen::Vector3d(tp[0], tp[1], tp[2])).norm();
      ss += e * e;
      far_off += e > kFarOffMm;
      ++added;
    }
  }
  const double added_rms_mm = added ? std::sqrt(ss / added) : 0;
  std::cout << "added (interior): " << added << ", RMS " << added_rms_mm << " mm, " << far_off
            << " beyond " << kFarOffMm << " mm\n";
  EXPECT_GT(added, 0);
  EXPECT_LT(added_rms_mm, kRmsTolMm);
  EXPECT_LE(far_off, kMaxFarOffFraction * added);
  // The stereo points are untouched: same positions wherever both have a point, and (outlier
  // removal aside, which sees the added neighbours) none lost.
  int lost = 0;
  for (size_t i = 0; i < stereo.cloud.valid.size(); ++i) {
    if (!stereo.cloud.valid[i]) continue;
    if (!tri.cloud.valid[i]) {
      ++lost;
      continue;
    }
    ASSERT_EQ(tri.cloud.cloud.points[i], stereo.cloud.cloud.points[i]);
  }
  EXPECT_LE(lost, stereo.summary.points / 1000);
  // Needs the projector.
  StereoRig no_projector = s.rig;
  no_projector.projector.reset();
  EXPECT_THROW(MakeTrinocularCorrespondence(no_projector, options.matching), Error);
}

}  // namespace
}  // namespace fringe::stereo
