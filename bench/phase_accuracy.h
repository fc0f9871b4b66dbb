// Accuracy measures of bench_phase: decoded phase against the synthetic truth (projector
// coordinate per camera pixel, phase::LinearProjectorMap or SceneMap), for our decoder and for
// OpenCV's structured_light peer (whose phase follows its own sign and offset convention).
#pragma once

#include <opencv2/core.hpp>

#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/synthetic.h"

namespace fringe::bench {

struct Accuracy {
  double wrapped_rms_rad = 0;
  double wrong_order_fraction = 0;
  double valid_fraction = 0;
  int64_t wrong = 0, valid = 0;
};

// Wrapped-phase RMS of set 0, wrong orders (|absolute error| > P/4) and valid fraction over the
// pixels of `region` (all pixels when empty); u_true: CV_32F projector column per pixel.
Accuracy Evaluate(const phase::PatternScheme& s, const phase::DecodeResult& r,
                  const cv::Mat& u_true, const cv::Mat& region = cv::Mat());

// RMS (projector px) of the absolute phase against the truth over valid pixels with the right
// order (|error| < P/4).
double AbsoluteRmsPx(const phase::PatternScheme& s, const phase::DecodeResult& r,
                     const cv::Mat& u_true);

// A scene: a tilted plane with smooth bumps and a raised block (a depth step shifts the
// projector coordinate by 7.3 px), so that spatial filtering is not free.
cv::Mat SceneMap(const phase::PatternScheme& s, cv::Size size);

// 16-bit synthetic stack with the SNR of an 8-bit one (B and sigma in 8-bit DN, scaled by 256)
// and unquantised patterns, so that the noise limit sqrt(2/N) sigma / B is exact.
phase::SyntheticStackOptions Gaussian16(double b, double sigma, uint64_t seed);

// OpenCV's phase follows its own pattern convention (sin, its shift sign): it is aligned to the
// truth with the best sign and constant offset before measuring, which favours OpenCV.
struct PeerAccuracy {
  double wrapped_rms_rad = 0;
  double unwrapped_rms_rad = 0;  // after removing the best constant (spatial unwrap is relative)
  double unwrap_error_fraction = 0;  // pixels off by more than pi after that
  double valid_fraction = 0;
  double central_rms_rad = 0;  // wrapped, inner 80 % x 80 % of the image (no DFT border effects)
};

// `unwrapped` may be empty (wrapped figures only); mask: CV_8U, non-zero where OpenCV decoded.
PeerAccuracy EvaluatePeer(const cv::Mat& wrapped, const cv::Mat& unwrapped, const cv::Mat& mask,
                          const phase::PatternScheme& s, const cv::Mat& u_true);

}  // namespace fringe::bench
