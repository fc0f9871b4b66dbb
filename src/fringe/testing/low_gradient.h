// Test-only helper shared by phase_matching_test.cc and bench/bench_captures.cc: the
// simulated view in which the cameras sample the projector at only 0.2-0.35 projector pixels
// per camera pixel, so that the phase advances by about its noise between neighbouring pixels
// (the situation of real captures with fine cameras or coarse projectors, where a matcher that
// takes a run's direction from one step loses streaks of rows). Exact ray tracing
// (testing/stereo_scene.h) gives the true projector column and surface point of every pixel; the
// fringe stack is rendered with phase::RenderSyntheticStack (camera noise sigma_dn) and decoded.
// Frames: left camera, mm.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "fringe/geometry/stereo_rig.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/synthetic.h"
#include "fringe/stereo/phase_matching.h"
#include "fringe/testing/stereo_scene.h"

namespace fringe::stereo::testing {

// The reference rig's cameras scaled by camera_scale and its projector by 0.4 * camera_scale:
// on the plane of MakeLowGradientCase the cameras sample the projector at 0.2-0.35 projector
// pixels per pixel (camera_scale 0.25: 320x256 cameras, 128x80 projector, the tests' size).
inline StereoRig LowGradientRig(double camera_scale) {
  StereoRig rig = ScaledReferenceRig(camera_scale);
  rig.projector = ScaleCamera(*StereoRig::Reference().projector, 0.4 * camera_scale);
  return rig;
}

// Renders the gray+4 fringe stack a camera sees for the projector columns `u` (NaN: unlit,
// which gets a flat grey without fringes) with camera noise sigma_dn and decodes it.
inline PhaseImage DecodedSyntheticView(const phase::PatternScheme& scheme, const cv::Mat& u,
                                       double modulation_dn, double sigma_dn, uint64_t seed) {
  cv::Mat lit = u == u;  // not NaN
  cv::Mat u_filled = u.clone();
  u_filled.setTo(0, ~lit);
  phase::SyntheticStackOptions so;
  so.modulation_dn = modulation_dn;
  so.noise_sigma_dn = sigma_dn;
  so.seed = seed;
  auto images = phase::RenderSyntheticStack(scheme, u_filled, so);
  for (auto& im : images) im.setTo(so.background_dn, ~lit);
  phase::DecodeOptions opt;
  opt.noise_sigma_dn = sigma_dn;
  const phase::DecodeResult d = phase::Decode(scheme, images, opt);
  PhaseImage p;
  p.phase = d.absolute_phase;
  p.mask = d.mask;
  p.modulation = d.modulation;
  return p;
}

// Fringe modulation of the low-gradient view: with sigma 1.5 DN and the gray+4 period of 32
// projector px the phase noise is 0.07 projector px, a quarter of the phase step per pixel.
constexpr double kLowGradientModulationDn = 80;

struct LowGradientCase {
  StereoRig rig;
  phase::PatternScheme scheme;
  TrueView left_truth;
  PhaseImage left, right;
};

// A plane ~480 mm in front of the left camera, tilted so that the phase advances slowly along
// the rows; both cameras decoded (seeds 101 and 202).
inline LowGradientCase MakeLowGradientCase(double camera_scale, double modulation_dn,
                                           double sigma_dn) {
  LowGradientCase c;
  c.rig = LowGradientRig(camera_scale);
  c.scheme = phase::MakeScheme("gray+4", c.rig.projector->width, c.rig.projector->height);
  Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0.25, -0.1, -1).normalized(), -480});
  c.left_truth = TraceView(c.rig, scene, false);
  const TrueView right_truth = TraceView(c.rig, scene, true);
  c.left = DecodedSyntheticView(c.scheme, c.left_truth.phase, modulation_dn, sigma_dn, 101);
  c.right = DecodedSyntheticView(c.scheme, right_truth.phase, modulation_dn, sigma_dn, 202);
  return c;
}

// The true phase advance per left pixel along the rows (every 8th row and column, lit pixels):
// the premise of the case, sorted.
inline std::vector<float> TruePhaseSteps(const LowGradientCase& c) {
  std::vector<float> steps;
  for (int r = 0; r < c.rig.left.height; r += 8) {
    for (int col = 0; col + 1 < c.rig.left.width; col += 8) {
      const float a = c.left_truth.phase.at<float>(r, col),
                  b = c.left_truth.phase.at<float>(r, col + 1);
      if (std::isfinite(a) && std::isfinite(b)) steps.push_back(b - a);
    }
  }
  std::sort(steps.begin(), steps.end());
  return steps;
}

// Valid left pixels whose true surface point the right camera sees (2 px inside its image) as
// a valid pixel: the pixels a matcher should match. *matched: how many of them have a point.
inline int EligiblePixels(const LowGradientCase& c, const MatchResult& m, int* matched) {
  int n = 0;
  *matched = 0;
  for (int r = 0; r < c.rig.left.height; ++r) {
    for (int col = 0; col < c.rig.left.width; ++col) {
      if (!c.left.mask.at<uint8_t>(r, col)) continue;
      const Eigen::Vector3d& p = c.left_truth.p_in_left[c.left_truth.phase.cols * r + col];
      if (!p.allFinite()) continue;
      const Eigen::Vector2d q = c.rig.right.Project(c.rig.right_from_left * p);
      if (q.x() < 2 || q.y() < 2 || q.x() > c.rig.right.width - 3 ||
          q.y() > c.rig.right.height - 3) {
        continue;
      }
      if (!c.right.mask.at<uint8_t>(static_cast<int>(std::lround(q.y())),
                                    static_cast<int>(std::lround(q.x())))) {
        continue;
      }
      ++n;
      *matched += m.cloud.valid[m.cloud.index(col, r)];
    }
  }
  return n;
}

}  // namespace fringe::stereo::testing
