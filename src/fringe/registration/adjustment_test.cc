#include "fringe/registration/adjustment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "fringe/util/error.h"

namespace fringe::registration {
namespace {

constexpr double kNoiseMm = 0.02;
// The loop closes to the noise level: 0.02 mm per sighting propagated over up to six views from
// the fixed one gives up to ~0.35 mm (errors scale with kNoiseMm; checked at 0.002 mm), against
// several millimetres of injected drift.
constexpr double kClosedLoopTolMm = 0.5;
constexpr double kClosedLoopRotTolDeg = 0.2;

// Twelve views around a ring of 36 markers, each view seeing 8 consecutive markers (neighbours
// share 5): a closed loop. Poses chained view to view with a small error each accumulate drift;
// the adjustment must close the loop.
TEST(AdjustMarkers, ClosesALoopWithInjectedDrift) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, kNoiseMm);
  std::vector<Eigen::Vector3d> markers;
  for (int k = 0; k < 36; ++k) {
    const double a = 2 * M_PI * k / 36;
    // Radius and height alternate so that every view's markers span a volume, not a line.
    const double r = k % 2 ? 180 : 120;
    markers.emplace_back(r * std::cos(a), r * std::sin(a), 25 * std::sin(3 * a) + (k % 3) * 15);
  }
  const int nv = 12;
  std::vector<Rigid3d> truth;
  for (int v = 0; v < nv; ++v) {
    const double a = 2 * M_PI * v / nv;
    truth.push_back(Rigid3d::FromAxisAngle(
        Eigen::Vector3d::UnitZ(), a, Eigen::Vector3d(150 * std::cos(a), 150 * std::sin(a), 400)));
  }
  std::vector<MarkerSighting> sightings;
  for (int v = 0; v < nv; ++v) {
    for (int j = 0; j < 8; ++j) {
      const int k = (3 * v + j) % 36;
      MarkerSighting s;
      s.view = v;
      s.marker = k;
      s.centre_in_sensor =
          truth[v].Inverse() * markers[k] + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      s.sigma_mm = kNoiseMm;
      sightings.push_back(s);
    }
  }
  // Drift: each view's start pose is the previous one's start times a slightly wrong motion.
  std::vector<Rigid3d> start = {truth[0]};
  for (int v = 1; v < nv; ++v) {
    const Rigid3d drift = Rigid3d::FromAxisAngle(Eigen::Vector3d(0.3, 1, 0.2).normalized(),
                                                 0.3 * M_PI / 180, Eigen::Vector3d(0.4, -0.3, 0.5));
    start.push_back(start[v - 1] * (truth[v - 1].Inverse() * truth[v]) * drift);
  }
  std::vector<Eigen::Vector3d> start_markers(36, Eigen::Vector3d::Zero());
  std::vector<int> count(36, 0);
  for (const auto& s : sightings) {
    start_markers[s.marker] += start[s.view] * s.centre_in_sensor;
    ++count[s.marker];
  }
  for (int k = 0; k < 36; ++k) start_markers[k] /= count[k];
  std::vector<bool> fixed(nv, false);
  fixed[0] = true;
  const AdjustmentResult r = AdjustMarkers(start, start_markers, sightings, fixed);
  ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
  EXPECT_GT(r.summary.rms_initial_mm, 1.0);  // the drift was real
  double start_max = 0;
  for (int k = 0; k < 36; ++k)
    start_max = std::max(start_max, (start_markers[k] - markers[k]).norm());
  EXPECT_GT(start_max, 10 * kClosedLoopTolMm);
  EXPECT_LT(r.summary.rms_final_mm, 2 * kNoiseMm);
  for (int v = 0; v < nv; ++v) {
    for (int j = 0; j < 8; ++j) {
      const int k = (3 * v + j) % 36;
      EXPECT_LT((r.markers_in_world[k] - markers[k]).norm(), kClosedLoopTolMm) << "marker " << k;
    }
    EXPECT_LT(Difference(r.world_from_sensor[v], truth[v]).angle_rad * 180 / M_PI,
              kClosedLoopRotTolDeg)
        << "view " << v;
  }
}

// Sightings far less certain along the sensor's viewing ray than across it, seen by views from
// different directions: with the covariances the adjustment takes each coordinate from the
// view that sees it across its ray; with scalar sigmas it averages the poor ones in.
TEST(AdjustMarkers, FullCovariancesBeatScalarSigmasForRayElongatedNoise) {
  constexpr double kAlongRayMm = 0.05, kAcrossRayMm = 0.005;
  std::mt19937 rng(5);
  std::normal_distribution<double> across(0, kAcrossRayMm), along(0, kAlongRayMm);
  std::uniform_real_distribution<double> u(-60, 60);
  std::vector<Eigen::Vector3d> markers;
  for (int k = 0; k < 20; ++k) markers.emplace_back(u(rng), u(rng), 0.3 * u(rng));
  std::vector<Rigid3d> truth;  // four views 60 deg apart around the part, 400 mm away
  for (int v = 0; v < 4; ++v) {
    const Rigid3d look = Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitY(), (v - 1.5) * M_PI / 3);
    truth.push_back(look * Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, -400)));
  }
  std::vector<MarkerSighting> full;
  for (int v = 0; v < 4; ++v) {
    for (int k = 0; k < 20; ++k) {
      MarkerSighting s;
      s.view = v;
      s.marker = k;
      const Eigen::Vector3d c = truth[v].Inverse() * markers[k];
      const Eigen::Vector3d ray = c.normalized(), a = ray.unitOrthogonal(), b = ray.cross(a);
      s.centre_in_sensor = c + along(rng) * ray + across(rng) * a + across(rng) * b;
      s.covariance_in_sensor =
          kAlongRayMm * kAlongRayMm * ray * ray.transpose() +
          kAcrossRayMm * kAcrossRayMm * (a * a.transpose() + b * b.transpose());
      s.sigma_mm = std::sqrt(s.covariance_in_sensor.trace());
      full.push_back(s);
    }
  }
  std::vector<MarkerSighting> scalar = full;
  for (MarkerSighting& s : scalar) s.covariance_in_sensor.setZero();
  std::vector<bool> fixed = {true, false, false, false};
  const AdjustmentResult rf = AdjustMarkers(truth, markers, full, fixed);
  const AdjustmentResult rs = AdjustMarkers(truth, markers, scalar, fixed);
  ASSERT_TRUE(rf.summary.ok()) << rf.summary.BriefReport();
  ASSERT_TRUE(rs.summary.ok()) << rs.summary.BriefReport();
  double ss_full = 0, ss_scalar = 0;
  for (int k = 0; k < 20; ++k) {
    ss_full += (rf.markers_in_world[k] - markers[k]).squaredNorm();
    ss_scalar += (rs.markers_in_world[k] - markers[k]).squaredNorm();
  }
  std::cout << "marker RMS error " << std::sqrt(ss_full / 20) << " mm with covariances, "
            << std::sqrt(ss_scalar / 20) << " mm with scalar sigmas\n";
  EXPECT_LT(ss_full, 0.25 * ss_scalar);
}

TEST(AdjustMarkers, BadSightingThrows) {
  std::vector<MarkerSighting> s(1);
  s[0].marker = 5;
  EXPECT_THROW(AdjustMarkers({Rigid3d()}, {Eigen::Vector3d::Zero()}, s, {true}), Error);
}

}  // namespace
}  // namespace fringe::registration
