// Projector gamma: the periodic phase error it causes, its removal, and its estimation.
//
// A projector with response out = in^gamma turns the sinusoid mean + amp cos(theta + shift_k)
// into a distorted periodic signal whose harmonics alias into the N-step least-squares estimate
// (harmonics N-1 and N+1 for equal shifts): the measured phase is psi = theta + delta(theta),
// a ripple with N cycles per fringe period ("waves" on flat surfaces). Because the camera adds
// only an affine map (background, gain), delta depends on gamma, the shifts and the pattern's
// mean/amplitude only, not on the pixel (Pan, Kemao, Huang, Asundi, "Phase error analysis and
// compensation for nonsinusoidal waveforms in phase-shifting digital fringe projection
// profilometry", Opt. Lett. 34, 2009). Two remedies: pre-compensate the patterns
// (GeneratePatterns(scheme, gamma)), or invert delta with a look-up table (GammaPhaseCorrection,
// DecodeOptions::projector_gamma, which corrects only what the scheme's gamma_precompensation
// left). EstimateGamma finds gamma from images of a smooth surface.
//
// Thread safety: GammaPhaseCorrection is immutable after construction; EstimateGamma is pure.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/phase/pattern_scheme.h"

namespace fringe::phase {

// psi(theta): the least-squares phase of the gamma-distorted samples
// (mean + amp cos(theta + shift_k))^gamma.
double GammaDistortedPhase(double theta, const std::vector<double>& shifts_rad, double mean,
                           double amplitude, double gamma);

// Maps a measured wrapped phase psi to the undistorted theta by a table (linear interpolation).
class GammaPhaseCorrection {
 public:
  GammaPhaseCorrection(const std::vector<double>& shifts_rad, double mean, double amplitude,
                       double gamma, int table_size = 4096);
  // psi in [-pi, pi] -> theta in (-pi, pi].
  float Correct(float psi) const {
    const float x = (psi + static_cast<float>(M_PI)) * scale_;
    int i = static_cast<int>(x);
    i = i < 0 ? 0 : (i >= size_ ? size_ - 1 : i);
    const float t = x - static_cast<float>(i);
    return psi + table_[i] + t * (table_[i + 1] - table_[i]);
  }
  // Largest |psi - theta| (radians): the ripple amplitude.
  double RippleAmplitude() const { return ripple_amplitude_; }

 private:
  std::vector<float> table_;  // size_ + 1 entries: theta - psi offsets added to psi
  int size_;
  float scale_;
  double ripple_amplitude_ = 0;
};

struct GammaEstimateOptions {
  // Search interval. 4-step sets alone are ambiguous below ~1.2 (their ripple vanishes at
  // gamma 1 and 2, and 0.87 mimics 2.2), and real projectors have gamma ~1.8-2.6.
  double min_gamma = 1.2;  // > 0
  double max_gamma = 4.0;  // > min_gamma
  int row_step = 2;        // use every row_step-th image row, >= 1
  void Check() const;
};

struct GammaEstimate {
  bool success = false;
  std::string message;
  double gamma = 1.0;
  double ripple_rms_before_px = 0;  // RMS of the high-passed phase (projector px), gamma = 1
  double ripple_rms_after_px = 0;   // same minus the ripple of the estimated gamma
  int64_t pixels_used = 0;
  std::string BriefReport() const;
};

// Estimates the projector gamma from a decoded stack of a smooth (e.g. flat) surface: the
// high-passed phase of every set along the image axis of the fringe direction is fitted by the
// high-passed ripple that gamma predicts (grid + golden-section search on log gamma). The
// patterns must not have been pre-compensated; the surface must be smooth over ~15 pixels.
// Use a 4-step scheme (heterodyne-4x3, gray+4): under strong uncompensated gamma the ripple of
// 3-step sets (~0.3 rad at gamma 2.2) breaks heterodyne unwrapping, so their stacks do not decode.
GammaEstimate EstimateGamma(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
                            const GammaEstimateOptions& options = {});

}  // namespace fringe::phase
