// RefineRig on synthetic scans with exact truth (no rendering: tilted planes seen by the true
// rig, the right camera's phase map computed per pixel, Gaussian noise on phases and marker
// centres): a perturbed rig is recovered; what the data cannot determine (one flat view with the
// intrinsics free, the right camera's yaw from markers alone) or nothing redundant (a few
// markers, no projector) is refused with the rig unchanged.
#include "fringe/calib/refine_rig.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <random>

#include "fringe/sim/renderer.h"
#include "fringe/util/error.h"

namespace fringe::calib {
namespace {

constexpr double kMarkerNoisePx = 0.03;  // marker centres on the reference rig (drift.h)
constexpr double kPhaseNoisePx = 0.02;   // decoded phase, projector pixels
// 3 views of 30 markers and 300 phase points each at these noises on the half-size rig: the
// right camera's orientation to 0.0005-0.0009 degrees (1 sigma per axis); a 0.03 degree drift
// must come back below this.
constexpr double kMaxRotationErrDeg = 0.002;
constexpr double kMaxBaselineErrMm = 0.05;
// The depth bend (TheSpheresDiameterUnbendsDepth): a right-camera yaw of this many degrees with
// the matching projector yaw flattens the test sphere's visible cap by ~0.75 % along depth.
constexpr double kBendYawDeg = 2.0;
// The target for the axis ratio after; the fit's own scatter at this noise and ~2000
// sphere points is ~0.0003.
constexpr double kMaxAxisRatioErr = 0.002;
constexpr double kMaxBendYawErrDeg = 0.01;
constexpr double kMaxBendBaselineErrMm = 0.2;

double AngleDeg(const Rigid3d& a, const Rigid3d& b) {
  return a.rotation().angularDistance(b.rotation()) * 180 / M_PI;
}

StereoRig Drifted(const StereoRig& rig, double angle_deg) {
  StereoRig out = rig;
  const double a = angle_deg * M_PI / 180;
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  out.right_from_left = Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitX(), a, zero) *
                        Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitY(), a, zero) *
                        Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitZ(), a, zero) *
                        rig.right_from_left;
  return out;
}

// One view: a tilted plane z = z0 + a x + b y (left frame) in front of the rig.
struct Plane {
  double z0, a, b;
  // The point of the plane on the ray origin + s * dir (s > 0), NaN when parallel or behind.
  Eigen::Vector3d Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) const {
    const double den = dir.z() - a * dir.x() - b * dir.y();
    const double s = (z0 - (origin.z() - a * origin.x() - b * origin.y())) / den;
    if (!(s > 0)) return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
    return origin + s * dir;
  }
};

Plane ViewPlane(int v, bool flat) {
  if (flat) return {500, 0.2, 0};
  const Plane planes[] = {{450, 0.25, -0.1}, {520, -0.3, 0.15}, {580, 0.1, 0.3}, {500, 0, -0.3}};
  return planes[v % 4];
}

// Views of planes seen by the rig `truth`, as a scan gives them: markers (both centres, noisy),
// phase points at left pixels (exact; their phase, the projector column, noisy) and the right
// camera's phase map (per pixel the projector column of the plane point it sees, noisy). The
// points' initial positions are the true ones (the refinement moves them with the rig).
RigRefinementData MakeData(const StereoRig& truth, int views, int markers, int points, bool flat,
                           uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> n(0, 1);
  RigRefinementData d;
  const Eigen::Matrix3d r_t = truth.right_from_left.rotation_matrix().transpose();
  const Eigen::Vector3d right_centre = -r_t * truth.right_from_left.translation();
  for (int v = 0; v < views; ++v) {
    const Plane plane = ViewPlane(v, flat);
    const auto on_plane_left = [&](const Eigen::Vector2d& px) {
      return plane.Intersect(Eigen::Vector3d::Zero(), truth.left.Unproject(px).homogeneous());
    };
    for (int i = 0; i < markers;) {
      const Eigen::Vector2d l0(u(rng) * truth.left.width, u(rng) * truth.left.height);
      const Eigen::Vector3d p = on_plane_left(l0);
      const Eigen::Vector2d r = truth.right.Project(truth.right_from_left * p);
      if (!p.allFinite() || !truth.left.InImage(l0, 5) || !truth.right.InImage(r, 5)) continue;
      d.markers.push_back({v, l0 + kMarkerNoisePx * Eigen::Vector2d(n(rng), n(rng)),
                           r + kMarkerNoisePx * Eigen::Vector2d(n(rng), n(rng)), p});
      ++i;
    }
    if (!truth.projector) continue;
    cv::Mat phase(truth.right.height, truth.right.width, CV_32F);
    for (int y = 0; y < phase.rows; ++y) {
      for (int x = 0; x < phase.cols; ++x) {
        const Eigen::Vector3d dir =
            r_t * truth.right.Unproject(Eigen::Vector2d(x, y)).homogeneous();
        const Eigen::Vector3d p = plane.Intersect(right_centre, dir);
        phase.at<float>(y, x) =
            p.allFinite()
                ? static_cast<float>(truth.projector->Project(truth.projector_from_left * p).x() +
                                     kPhaseNoisePx * n(rng))
                : std::numeric_limits<float>::quiet_NaN();
      }
    }
    d.right_phase.push_back(phase);
    for (int i = 0; i < points;) {
      const Eigen::Vector2d l(std::floor(u(rng) * truth.left.width),
                              std::floor(u(rng) * truth.left.height));
      const Eigen::Vector3d p = on_plane_left(l);
      if (!p.allFinite()) continue;
      const Eigen::Vector2d q = truth.projector->Project(truth.projector_from_left * p);
      const Eigen::Vector2d r = truth.right.Project(truth.right_from_left * p);
      if (!truth.projector->InImage(q, 5) || !truth.right.InImage(r, 10)) continue;
      // The left pixel is where the point was measured: exact; its phase carries the noise.
      d.points.push_back({v, l, q.x() + kPhaseNoisePx * n(rng), p});
      ++i;
    }
  }
  return d;
}

// Options with the simulated noise stated and the given scale reference.
RigRefinementOptions WithNoise(RefineScale scale) {
  RigRefinementOptions o;
  o.scale = scale;
  o.marker_sigma_px = kMarkerNoisePx;
  o.phase_sigma_px = kPhaseNoisePx;
  return o;
}

TEST(RigRefinementOptions, DefaultsPassCheck) {
  EXPECT_NO_THROW(RigRefinementOptions().Check());
  RigRefinementOptions o;
  o.phase_sigma_px = 0;
  EXPECT_THROW(o.Check(), Error);
}

// A right camera turned by 0.03 degrees about each axis: markers and projector columns bring it
// back with the projector held (the scale and the columns' reference); the residuals fall to
// the noise.
TEST(RefineRig, RecoversADriftedRightCamera) {
  const StereoRig truth = sim::ScaledRig(StereoRig::Reference(), 0.5);
  const StereoRig drifted = Drifted(truth, 0.03);
  ASSERT_GT(AngleDeg(drifted.right_from_left, truth.right_from_left), 0.05);
  const RigRefinementData data = MakeData(truth, 3, 30, 300, false, 7);
  const RigRefinementOptions o = WithNoise(RefineScale::kProjector);
  const RigRefinement r = RefineRig(drifted, data, o);
  ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
  const double err = AngleDeg(r.rig.right_from_left, truth.right_from_left);
  EXPECT_LT(err, kMaxRotationErrDeg) << r.summary.BriefReport();
  EXPECT_NEAR(r.rig.BaselineMm(), truth.BaselineMm(), kMaxBaselineErrMm);
  EXPECT_GT(r.summary.marker_epipolar_rms_before_px, 10 * r.summary.marker_epipolar_rms_after_px);
  EXPECT_LT(r.summary.marker_epipolar_rms_after_px, 2 * kMarkerNoisePx);
  // Every refined parameter is reported with a finite, positive uncertainty.
  ASSERT_FALSE(r.summary.parameters.empty());
  for (const RefinedParameter& p : r.summary.parameters) {
    EXPECT_GT(p.sigma, 0) << p.name;
    EXPECT_TRUE(std::isfinite(p.after)) << p.name;
  }
  // The rotation error is consistent with the stated uncertainty (a few sigmas).
  double sigma_deg = 0;
  for (const RefinedParameter& p : r.summary.parameters) {
    if (p.name.rfind("right_from_left rotation", 0) == 0) sigma_deg = std::max(sigma_deg, p.sigma);
  }
  EXPECT_LT(err, 5 * std::sqrt(3.0) * sigma_deg);
}

// A drift far below what the data resolve (0.0002 degrees about each axis against sigmas of
// 0.0005-0.0009 degrees): the bundle moves the rig by its noise, not towards the truth, so the
// change is not significant against its own uncertainty; the refinement says so and leaves the
// rig as it was (it used to report ok and return the noise-moved rig).
TEST(RefineRig, AChangeWithinItsOwnUncertaintyIsNotAccepted) {
  const StereoRig truth = sim::ScaledRig(StereoRig::Reference(), 0.5);
  const StereoRig drifted = Drifted(truth, 0.0002);
  const RigRefinementData data = MakeData(truth, 3, 30, 300, false, 7);
  const RigRefinementOptions o = WithNoise(RefineScale::kProjector);
  const RigRefinement r = RefineRig(drifted, data, o);
  EXPECT_EQ(r.summary.status, RefineStatus::kNotSignificant) << r.summary.BriefReport();
  EXPECT_FALSE(r.summary.ok());
  EXPECT_NE(r.summary.message.find("no significant change"), std::string::npos)
      << r.summary.message;
  EXPECT_NE(r.summary.message.find("rig is unchanged"), std::string::npos);
  EXPECT_EQ(r.rig.right_from_left.rotation().coeffs(), drifted.right_from_left.rotation().coeffs());
  EXPECT_EQ(r.rig.right_from_left.translation(), drifted.right_from_left.translation());
  // The same data with the 0.03 degree drift: significant, accepted, closer to the truth.
  const StereoRig far = Drifted(truth, 0.03);
  const RigRefinement f = RefineRig(far, data, o);
  ASSERT_TRUE(f.summary.ok()) << f.summary.BriefReport();
  EXPECT_GE(f.summary.solve_rounds, 2);
  EXPECT_LT(AngleDeg(f.rig.right_from_left, truth.right_from_left), kMaxRotationErrDeg);
}

// One flat view with the intrinsics free: focal lengths and depth trade off on a plane; the
// refinement says which parameters are not determined and leaves the rig as it was.
TEST(RefineRig, OneFlatViewWithFreeIntrinsicsIsNotDetermined) {
  const StereoRig truth = sim::ScaledRig(StereoRig::Reference(), 0.5);
  StereoRig rig = Drifted(truth, 0.03);
  rig.projector.reset();
  RigRefinementData data = MakeData(truth, 1, 40, 0, true, 3);
  RigRefinementOptions o;
  o.intrinsics = true;
  const RigRefinement r = RefineRig(rig, data, o);
  EXPECT_EQ(r.summary.status, RefineStatus::kNotDetermined) << r.summary.BriefReport();
  EXPECT_NE(r.summary.message.find("do not determine"), std::string::npos) << r.summary.message;
  EXPECT_NE(r.summary.message.find("rig is unchanged"), std::string::npos);
  EXPECT_EQ(r.rig.right_from_left.translation(), rig.right_from_left.translation());
  EXPECT_EQ(r.rig.right_from_left.rotation().coeffs(), rig.right_from_left.rotation().coeffs());
  EXPECT_EQ(r.rig.left, rig.left);
  EXPECT_EQ(r.rig.right, rig.right);
}

// No projector and too few markers: nothing redundant, nothing refined.
TEST(RefineRig, NoRedundantEvidenceLeavesTheRigUnchanged) {
  StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.5);
  rig.projector.reset();
  const RigRefinementData data = MakeData(rig, 1, 3, 0, false, 5);
  const RigRefinement r = RefineRig(rig, data);
  EXPECT_EQ(r.summary.status, RefineStatus::kNoEvidence);
  EXPECT_NE(r.summary.message.find("nothing constrains the rig"), std::string::npos);
  EXPECT_EQ(r.rig.right_from_left.translation(), rig.right_from_left.translation());
}

// The baseline holding the scale (the projector's orientation still holds the depth gauge, its
// translation is refined): the right camera's orientation comes back as well, the baseline
// stays.
TEST(RefineRig, BaselineHeldRecoversTheOrientation) {
  const StereoRig truth = sim::ScaledRig(StereoRig::Reference(), 0.5);
  const StereoRig drifted = Drifted(truth, 0.03);
  const RigRefinementData data = MakeData(truth, 3, 30, 300, false, 7);
  const RigRefinementOptions o = WithNoise(RefineScale::kBaseline);
  const RigRefinement r = RefineRig(drifted, data, o);
  ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
  EXPECT_EQ(r.summary.scale, RefineScale::kBaseline);
  EXPECT_LT(AngleDeg(r.rig.right_from_left, truth.right_from_left), kMaxRotationErrDeg);
  EXPECT_NEAR(r.rig.BaselineMm(), drifted.BaselineMm(), 1e-9);
  EXPECT_LT(AngleDeg(r.rig.projector_from_left, drifted.projector_from_left), 1e-9);
}

// Without a calibrated projector, markers alone: a yaw of the right camera trades against the
// markers' depths (it shifts every horizontal disparity alike), so it is not determined even
// with 90 markers in 3 views: the refinement names it and leaves the rig unchanged.
TEST(RefineRig, MarkersAloneLeaveTheYawUndetermined) {
  const StereoRig truth = sim::ScaledRig(StereoRig::Reference(), 0.5);
  StereoRig drifted = Drifted(truth, 0.03);
  drifted.projector.reset();
  const RigRefinementData data = MakeData(truth, 3, 30, 0, false, 7);
  RigRefinementOptions o;
  o.marker_sigma_px = kMarkerNoisePx;
  const RigRefinement r = RefineRig(drifted, data, o);
  EXPECT_EQ(r.summary.status, RefineStatus::kNotDetermined) << r.summary.BriefReport();
  EXPECT_NE(r.summary.message.find("right_from_left rotation y"), std::string::npos)
      << r.summary.message;
  EXPECT_NE(r.summary.message.find("rig is unchanged"), std::string::npos);
  EXPECT_EQ(r.rig.right_from_left.rotation().coeffs(), drifted.right_from_left.rotation().coeffs());
  EXPECT_EQ(r.rig.right_from_left.translation(), drifted.right_from_left.translation());
}

// A sphere of radius kSphereRadiusMm in front of the rig on a background plane with markers: the
// scan of a certified sphere. Right yaw + matching projector yaw (BendDepth) flatten it along
// depth while every observation stays consistent; the initial points are what the bent rig
// triangulates from the true left and right pixels (as the stereo matcher would).
constexpr double kSphereRadiusMm = 30;
const Eigen::Vector3d kSphereCentre(0, 0, 480);
constexpr Plane kBackground{520, 0.2, 0.1};

// Nearest hit of the ray origin + s dir (dir unit, s > 0) on the sphere or else the background.
Eigen::Vector3d HitScene(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                         bool* on_sphere) {
  const Eigen::Vector3d oc = origin - kSphereCentre;
  const double b = oc.dot(dir),
               disc = b * b - (oc.squaredNorm() - kSphereRadiusMm * kSphereRadiusMm);
  *on_sphere = disc > 0 && -b - std::sqrt(disc) > 0;
  if (*on_sphere) return origin + (-b - std::sqrt(disc)) * dir;
  return kBackground.Intersect(origin, dir);
}

// Least-squares meeting point of the left ray of `l` and the right ray of `r` under `rig`.
Eigen::Vector3d MeetRays(const StereoRig& rig, const Eigen::Vector2d& l, const Eigen::Vector2d& r) {
  const Eigen::Matrix3d r_t = rig.right_from_left.rotation_matrix().transpose();
  const Eigen::Vector3d o2 = -r_t * rig.right_from_left.translation();
  const Eigen::Vector3d d1 = rig.left.Unproject(l).homogeneous().normalized();
  const Eigen::Vector3d d2 = (r_t * rig.right.Unproject(r).homogeneous()).normalized();
  Eigen::Matrix<double, 3, 2> a;
  a << d1, -d2;
  const Eigen::Vector2d st = a.colPivHouseholderQr().solve(o2);
  return 0.5 * (st[0] * d1 + o2 + st[1] * d2);
}

// The rig with the right camera turned by yaw_deg about its y axis and the projector about its
// own y axis by the angle that keeps the sphere's centre on its projector column (the depth bend
// of the header, to first order consistent everywhere).
StereoRig BendDepth(const StereoRig& truth, double yaw_deg) {
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  StereoRig bent = truth;
  bent.right_from_left =
      Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitY(), yaw_deg * M_PI / 180, zero) *
      truth.right_from_left;
  const Eigen::Vector2d l = truth.left.Project(kSphereCentre);
  const Eigen::Vector2d r = truth.right.Project(truth.right_from_left * kSphereCentre);
  const Eigen::Vector3d moved = MeetRays(bent, l, r);
  const double column = truth.projector->Project(truth.projector_from_left * kSphereCentre).x();
  const auto miss = [&](double yaw) {
    return truth.projector
               ->Project(Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitY(), yaw, zero) *
                         truth.projector_from_left * moved)
               .x() -
           column;
  };
  double y0 = 0, y1 = 1e-3, f0 = miss(y0), f1 = miss(y1);
  for (int it = 0; it < 20 && std::abs(f1) > 1e-9 && f1 != f0; ++it) {
    const double y2 = y1 - f1 * (y1 - y0) / (f1 - f0);
    y0 = y1;
    f0 = f1;
    y1 = y2;
    f1 = miss(y1);
  }
  bent.projector_from_left =
      Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitY(), y1, zero) * truth.projector_from_left;
  return bent;
}

// The sphere scene seen by `truth`, its points triangulated by `measuring` (the rig the scan
// used). Sphere points name sphere 0 of their view; `mark_sphere` false leaves them unmarked.
RigRefinementData MakeSphereData(const StereoRig& truth, const StereoRig& measuring, int points,
                                 int markers, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> n(0, 1);
  RigRefinementData d;
  const Eigen::Matrix3d r_t = truth.right_from_left.rotation_matrix().transpose();
  const Eigen::Vector3d right_centre = -r_t * truth.right_from_left.translation();
  cv::Mat phase(truth.right.height, truth.right.width, CV_32F);
  for (int y = 0; y < phase.rows; ++y) {
    for (int x = 0; x < phase.cols; ++x) {
      bool sphere = false;
      const Eigen::Vector3d p = HitScene(
          right_centre,
          (r_t * truth.right.Unproject(Eigen::Vector2d(x, y)).homogeneous()).normalized(), &sphere);
      phase.at<float>(y, x) =
          p.allFinite()
              ? static_cast<float>(truth.projector->Project(truth.projector_from_left * p).x() +
                                   kPhaseNoisePx * n(rng))
              : std::numeric_limits<float>::quiet_NaN();
    }
  }
  d.right_phase.push_back(phase);
  d.spheres.push_back({0, kSphereCentre});
  // Points: half of them aimed at the sphere (it covers a small part of the image).
  const Eigen::Vector2d c = truth.left.Project(kSphereCentre);
  const double reach_px = 1.2 * truth.left.fx * kSphereRadiusMm / kSphereCentre.z();
  for (int i = 0; i < points;) {
    const Eigen::Vector2d l =
        i % 2 ? Eigen::Vector2d(std::floor(u(rng) * truth.left.width),
                                std::floor(u(rng) * truth.left.height))
              : Eigen::Vector2d(std::floor(c.x() + reach_px * (2 * u(rng) - 1)),
                                std::floor(c.y() + reach_px * (2 * u(rng) - 1)));
    bool sphere = false;
    const Eigen::Vector3d p = HitScene(Eigen::Vector3d::Zero(),
                                       truth.left.Unproject(l).homogeneous().normalized(), &sphere);
    if (!p.allFinite()) continue;
    const Eigen::Vector2d q = truth.projector->Project(truth.projector_from_left * p);
    const Eigen::Vector2d r = truth.right.Project(truth.right_from_left * p);
    if (!truth.projector->InImage(q, 5) || !truth.right.InImage(r, 10)) continue;
    // Occluded in the right camera: its ray meets the scene elsewhere first.
    bool seen_on_sphere = false;
    const Eigen::Vector3d seen =
        HitScene(right_centre, (p - right_centre).normalized(), &seen_on_sphere);
    if ((seen - p).norm() > 1e-6) continue;
    // Near the sphere's outline in the right image the bicubic phase mixes sphere and background
    // (a real scan's edge filter drops such pixels): left out.
    bool mixed = false;
    for (const Eigen::Vector2d& o : {Eigen::Vector2d(3, 3), Eigen::Vector2d(-3, 3),
                                     Eigen::Vector2d(3, -3), Eigen::Vector2d(-3, -3)}) {
      bool corner_on_sphere = false;
      HitScene(right_centre, (r_t * truth.right.Unproject(r + o).homogeneous()).normalized(),
               &corner_on_sphere);
      mixed = mixed || corner_on_sphere != sphere;
    }
    if (mixed) continue;
    RefinePhasePoint pt{0, l, q.x() + kPhaseNoisePx * n(rng), MeetRays(measuring, l, r)};
    pt.sphere = sphere ? 0 : -1;
    d.points.push_back(pt);
    ++i;
  }
  for (int i = 0; i < markers;) {
    const Eigen::Vector2d l(u(rng) * truth.left.width, u(rng) * truth.left.height);
    bool sphere = false;
    const Eigen::Vector3d p = HitScene(Eigen::Vector3d::Zero(),
                                       truth.left.Unproject(l).homogeneous().normalized(), &sphere);
    if (!p.allFinite() || sphere) continue;
    const Eigen::Vector2d r = truth.right.Project(truth.right_from_left * p);
    if (!truth.left.InImage(l, 5) || !truth.right.InImage(r, 5)) continue;
    d.markers.push_back({0, l + kMarkerNoisePx * Eigen::Vector2d(n(rng), n(rng)),
                         r + kMarkerNoisePx * Eigen::Vector2d(n(rng), n(rng)),
                         MeetRays(measuring, l, r)});
    ++i;
  }
  return d;
}

// The sphere constraint's options: the simulated noise, the certified diameter.
RigRefinementOptions WithSphere() {
  RigRefinementOptions o = WithNoise(RefineScale::kAuto);
  o.sphere = RefineSphere{2 * kSphereRadiusMm, 0.005};
  return o;
}

TEST(FitSpheroid, MeasuresAFlattenedCap) {
  // The front half of a spheroid with semi-axes 20 (across) and 19 (along z), seen along z.
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 30; ++i) {
    for (int j = 0; j < 60; ++j) {
      const double polar = 0.5 * M_PI * i / 30, azimuth = 2 * M_PI * j / 60;
      pts.emplace_back(20 * std::sin(polar) * std::cos(azimuth),
                       20 * std::sin(polar) * std::sin(azimuth), 500 - 19 * std::cos(polar));
    }
  }
  const SpheroidFit fit = FitSpheroid(pts, Eigen::Vector3d::UnitZ());
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.across_mm, 20, 1e-9);
  EXPECT_NEAR(fit.along_mm, 19, 1e-9);
  EXPECT_NEAR(fit.axis_ratio(), 0.95, 1e-9);
  EXPECT_LT((fit.centre - Eigen::Vector3d(0, 0, 500)).norm(), 1e-9);
  EXPECT_FALSE(FitSpheroid({pts.begin(), pts.begin() + 5}, Eigen::Vector3d::UnitZ()).ok);
}

// Issue 26: a right camera + projector yaw that flattens the sphere along depth, nearly
// invisible to the observations; the certified diameter brings the yaws back and the sphere
// round. The yaw error bound is the acceptance limit on a rotation sigma (0.01 deg).
TEST(RefineRig, TheSpheresDiameterUnbendsDepth) {
  const StereoRig truth = sim::ScaledRig(StereoRig::Reference(), 0.5);
  const StereoRig bent = BendDepth(truth, kBendYawDeg);
  const RigRefinementData data = MakeSphereData(truth, bent, 7000, 30, 11);
  const RigRefinement r = RefineRig(bent, data, WithSphere());
  ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
  EXPECT_EQ(r.summary.scale, RefineScale::kArtefact);
  EXPECT_EQ(r.summary.spheres, 1);
  EXPECT_GT(r.summary.sphere_points, 300);
  EXPECT_LT(r.summary.sphere_axis_ratio_before, 1 - 3 * kMaxAxisRatioErr)
      << r.summary.BriefReport();
  EXPECT_NEAR(r.summary.sphere_axis_ratio_after, 1, kMaxAxisRatioErr) << r.summary.BriefReport();
  EXPECT_LT(AngleDeg(r.rig.right_from_left, truth.right_from_left), kMaxBendYawErrDeg)
      << r.summary.BriefReport();
  EXPECT_LT(AngleDeg(r.rig.projector_from_left, truth.projector_from_left), kMaxBendYawErrDeg)
      << r.summary.BriefReport();
  EXPECT_NEAR(r.rig.BaselineMm(), truth.BaselineMm(), kMaxBendBaselineErrMm);
  EXPECT_NE(r.summary.BriefReport().find("axis ratio"), std::string::npos);
}

// The axis ratio of the data's sphere points as `rig` triangulates their true left and right
// pixels (the matcher's pair), along the view.
double SphereRatioUnder(const StereoRig& rig, const StereoRig& truth, const RigRefinementData& d) {
  std::vector<Eigen::Vector3d> pts;
  for (const RefinePhasePoint& p : d.points) {
    if (p.sphere < 0) continue;
    bool on = false;
    const Eigen::Vector3d x = HitScene(
        Eigen::Vector3d::Zero(), truth.left.Unproject(p.left_px).homogeneous().normalized(), &on);
    pts.push_back(MeetRays(rig, p.left_px, truth.right.Project(truth.right_from_left * x)));
  }
  return FitSpheroid(pts, kSphereCentre.normalized()).axis_ratio();
}

// The same scan without the diameter: the observations see the yaw pair only in part (markers'
// vertical disparities, second-order column errors) and the projector's yaw holds the gauge, so
// whatever is refined, the sphere stays flattened.
TEST(RefineRig, WithoutTheDiameterTheBendStays) {
  const StereoRig truth = sim::ScaledRig(StereoRig::Reference(), 0.5);
  const StereoRig bent = BendDepth(truth, kBendYawDeg);
  const RigRefinementData data = MakeSphereData(truth, bent, 7000, 30, 11);
  ASSERT_LT(SphereRatioUnder(bent, truth, data), 1 - 3 * kMaxAxisRatioErr);
  const RigRefinement r = RefineRig(bent, data, WithNoise(RefineScale::kAuto));
  EXPECT_LT(SphereRatioUnder(r.rig, truth, data), 1 - 3 * kMaxAxisRatioErr)
      << r.summary.BriefReport();
  EXPECT_LT(AngleDeg(r.rig.projector_from_left, bent.projector_from_left), 1e-9);
  EXPECT_EQ(r.summary.sphere_points, 0);
  // With the diameter, the same measure of the refined rig is round.
  const RigRefinement with = RefineRig(bent, data, WithSphere());
  ASSERT_TRUE(with.summary.ok()) << with.summary.BriefReport();
  EXPECT_NEAR(SphereRatioUnder(with.rig, truth, data), 1, kMaxAxisRatioErr);
}

// A sphere asked for and none in the data (planes, no point on a sphere): said so, rig unchanged.
TEST(RefineRig, ASphereAskedForButNotInTheDataIsRefused) {
  const StereoRig truth = sim::ScaledRig(StereoRig::Reference(), 0.5);
  const StereoRig drifted = Drifted(truth, 0.03);
  const RigRefinementData data = MakeData(truth, 3, 30, 300, false, 7);
  const RigRefinement r = RefineRig(drifted, data, WithSphere());
  EXPECT_EQ(r.summary.status, RefineStatus::kNoEvidence) << r.summary.BriefReport();
  EXPECT_NE(r.summary.message.find("no sphere was found"), std::string::npos) << r.summary.message;
  EXPECT_EQ(r.rig.right_from_left.rotation().coeffs(), drifted.right_from_left.rotation().coeffs());
  RigRefinementOptions artefact_scale_without_sphere = WithNoise(RefineScale::kArtefact);
  EXPECT_THROW(RefineRig(drifted, data, artefact_scale_without_sphere), Error);
}

}  // namespace
}  // namespace fringe::calib
