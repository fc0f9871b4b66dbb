#include "fringe/registration/adjustment.h"

#include <gtest/gtest.h>

#include <cmath>
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

TEST(AdjustMarkers, BadSightingThrows) {
  std::vector<MarkerSighting> s(1);
  s[0].marker = 5;
  EXPECT_THROW(AdjustMarkers({Rigid3d()}, {Eigen::Vector3d::Zero()}, s, {true}), Error);
}

}  // namespace
}  // namespace fringe::registration
