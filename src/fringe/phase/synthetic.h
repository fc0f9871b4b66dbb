// Synthetic fringe image stacks with known projector coordinates, for tests and benchmarks.
//
// Each camera pixel sees projector coordinate u (a CV_32F map, projector pixels along the fringe
// direction). The projector shows the scheme's 8-bit patterns (optionally pre-compensated for a
// gamma), its response is out = in^projector_gamma, and the camera records
//     I = background_dn + modulation_dn * (2 * out - 1)   (so sinusoids are A + B cos(...))
// plus Gaussian noise, rounded and clamped to the bit depth. Deterministic for a seed,
// independent of the thread count (per-row generators from util::MixSeed).
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "fringe/phase/pattern_scheme.h"

namespace fringe::phase {

struct SyntheticStackOptions {
  double background_dn = 128.0;      // A, DN
  double modulation_dn = 100.0;      // B, DN (>= 0)
  double noise_sigma_dn = 2.0;       // Gaussian camera noise, DN (>= 0)
  double projector_gamma = 1.0;      // projector response exponent (> 0)
  double precompensate_gamma = 1.0;  // gamma the 8-bit patterns were pre-compensated for (> 0)
  bool quantize_patterns = true;     // 8-bit projector patterns (false: ideal continuous ones)
  int bit_depth = 8;                 // 8 or 16 (camera)
  uint64_t seed = 1;
  void Check() const;
};

// A smooth map covering the projector span across the image (with a slight shear along y).
cv::Mat LinearProjectorMap(const PatternScheme& scheme, cv::Size size);

std::vector<cv::Mat> RenderSyntheticStack(const PatternScheme& scheme, const cv::Mat& projector_u,
                                          const SyntheticStackOptions& options);

}  // namespace fringe::phase
