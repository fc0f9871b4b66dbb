// Decoding one camera's fringe image stack to absolute phase, modulation and a quality mask.
//
// Per pixel and phase-shift set, the N intensities I_k = A + B cos(phi + shift_k) give A, B and
// the wrapped phase phi by linear least squares (any N >= 3, any known shifts; for equally spaced
// shifts this is the classic N-step formula). Absolute phase (docs/formats.md, "Pattern scheme
// manifest"; projector pixels u along the fringe direction) then comes from
//  - multi-frequency heterodyne unwrapping (Reich et al. 1997, "Fringe projection with
//    multi-frequency phase shifting"; the thesis' 4+3+3 scheme): beat phases of adjacent
//    frequencies level by level until one covers the projector, then orders are fixed top down;
//  - or complementary Gray code (Zhang, Su, Xiang, Sun, Opt. Lasers Eng. 50, 2012): the extra
//    half-period-shifted bit decides the order near period edges, so there are no edge jumps.
// Fringe-order consistency: every unwrapping step's rounding residual must stay below
// DecodeOptions::max_order_residual (else "order_ambiguous"), and a spatial check compares each
// pixel with the median of its valid 5x5 neighbourhood, repairing an order that is off by whole
// periods or rejecting the pixel.
//
// Noise analysis: with camera noise sigma_I and modulation B, the wrapped phase of an N-step
// set has sigma_phi = sqrt(2/N) sigma_I / B (equally spaced shifts). Once the fringe orders are
// fixed, every set of a multi-frequency scheme measures the same projector coordinate with
// variance (P_s / 2 pi)^2 sigma_phi_s^2; the decoder combines them by inverse variance (the
// whole stack's limit, AbsolutePhaseSigmaPx). Each unwrapping step is a
// linear combination of the sets' phases whose error must stay below half a fine period; this
// gives the modulation below which a wrong order becomes likely (ModulationThreshold), which is
// the default modulation threshold of the mask.
//
// Thread safety: Decode is reentrant; it runs TBB over image rows and its results do not depend
// on the number of threads.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "fringe/phase/pattern_scheme.h"

namespace fringe::phase {

// Least-squares demodulation of one phase-shift set with the model
// I_k = A + a cos(shift_k) - b sin(shift_k) (a = B cos phi, b = B sin phi): returns the 3 x N
// CV_64F matrix C with (A, a, b) = C * (I_0 .. I_{N-1}), and in *cov (when given) (M^T M)^-1,
// the covariance of (A, a, b) per unit noise variance. Shared by the decoder and the gamma
// model so both demodulate identically.
cv::Mat DemodulationMatrix(const std::vector<double>& shifts, cv::Matx33d* cov = nullptr);
// The same for a set, whose flat steps (PhaseShiftSet::flat_steps) have the design row [1, 0, 0].
cv::Mat DemodulationMatrix(const PhaseShiftSet& set, cv::Matx33d* cov = nullptr);

// Camera noise assumed when it can be neither given nor estimated (a scheme of 3-step sets only
// has no least-squares residual), DN.
constexpr double kAssumedNoiseSigmaDn = 2.0;

struct DecodeOptions {
  // Camera noise standard deviation (DN of the images' bit depth), >= 0; 0 estimates it from
  // the images (EstimateNoise). Only used to derive the automatic modulation threshold.
  double noise_sigma_dn = 0.0;
  // Probability of a wrong fringe order per pixel at the automatic modulation threshold,
  // in (0, 0.1).
  double order_error_probability = 1e-6;
  // Modulation threshold B_min in DN; <= 0 selects ModulationThreshold(scheme, noise_sigma_dn,
  // order_error_probability). Tested on set 0 (the measuring frequency).
  double min_modulation_dn = 0.0;
  // Full scale of the camera in DN; <= 0 means that of the image depth (255 or 65535). Set it
  // for 10- or 12-bit sensors stored in 16-bit images (e.g. 4095).
  double full_scale_dn = 0.0;
  // Saturation level (DN): a pixel is rejected when an image of a phase-shift set reaches it
  // (a Gray-code or white frame may saturate: its bright decision stays unambiguous); <= 0
  // means the full scale.
  double saturation_dn = 0.0;
  // Under-exposure: background A of set 0 below this fraction of full scale, in [0, 1).
  double min_background_fraction = 0.01;
  // Shadow: modulation over background B/A of set 0 below this, in [0, 1). Shadowed pixels keep
  // ambient light but lose fringe contrast.
  double min_modulation_ratio = 0.05;
  // Largest accepted rounding residual of a heterodyne unwrapping step, in fractions of the finer
  // period, (0, 0.5]. Larger residuals mean the order is ambiguous; the pixel is rejected.
  double max_order_residual = 0.4;
  // Spatial order check against the median of the valid 5x5 neighbourhood, in fractions of the
  // measuring period, (0, 1]; <= 0 disables the check.
  double spatial_check_fraction = 0.5;
  // When the spatial check fails: shift the pixel by whole periods if that agrees with the
  // neighbourhood (true), or reject it (false, or when no shift agrees).
  bool repair_orders = true;
  // Multi-frequency (heterodyne) schemes: once the orders are known, the absolute phase is the
  // inverse-variance weighted mean of every set's estimate (weights B_s^2 N_s / P_s^2 for equal
  // shifts) instead of the finest set's alone. false: the finest set alone (~1.6x the noise on
  // heterodyne-4x3).
  bool whole_stack = true;
  // Measured response exponent of the projector (out = in^gamma); 0 = unknown (the default).
  // What was projected is the scheme's business: PatternScheme::gamma_precompensation. The
  // decoder removes, with a look-up table (gamma.h), only the part the patterns did not
  // pre-compensate, exponent projector_gamma / gamma_precompensation; nothing when the two agree
  // or the gamma is unknown. One source of truth: there is no separate "correct by" knob.
  double projector_gamma = 0;

  // The exponent left uncorrected in images of `scheme`, 1 when none (see projector_gamma).
  double ResidualGamma(const PatternScheme& scheme) const;

  void Check() const;  // throws fringe::Error naming the field
};

// The automatic modulation threshold never exceeds this fraction of the full scale: a scheme
// whose unwrapping margin asks for more (a beat of beats equal to the projector span) would
// otherwise reject every pixel.
constexpr double kMaxModulationThresholdFraction = 0.25;

// Where the camera noise used for the modulation threshold came from.
enum class NoiseSource { kGiven, kEstimated, kAssumed };
const char* ToString(NoiseSource s);

struct NoiseEstimate {
  double sigma_dn = kAssumedNoiseSigmaDn;
  NoiseSource source = NoiseSource::kAssumed;
  int set = -1;         // phase set whose residual gave the estimate, -1 when assumed
  int64_t pixels = 0;   // pixels used
  std::string message;  // how it was obtained, for the summary
};

// Camera noise from the least-squares residual of the first phase set with N >= 4 steps. The
// residual also carries what the sinusoid misses (projector-gamma harmonics: on uncompensated
// patterns they exceed the noise several times), which varies smoothly with the phase; so the
// estimate uses the third difference of four neighbouring pixels' residual vectors, along rows
// and along columns, and keeps the smaller: |-e(0) + 3 e(1) - 3 e(2) + e(3)|^2 / (20 (N - 3))
// has mean sigma^2 for independent noise. The median over unclipped pixels (every 2nd column of
// every 2nd row, or of 128 evenly spread rows on taller images), divided by the median of
// chi^2 / dof, is robust to edges and defects. Without a set of N >= 4 the result is
// kAssumedNoiseSigmaDn with source kAssumed. full_scale_dn: pixels reaching it
// (or 0) in the set are skipped.
NoiseEstimate EstimateNoise(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
                            double full_scale_dn);

// The camera noise and the modulation threshold of one decode, the same for every decoder
// (temporal, spatial, pure Gray code): the noise given (DecodeOptions::noise_sigma_dn), else,
// when the threshold is automatic, estimated (EstimateNoise; a pure Gray code has no phase set to
// estimate it from and assumes kAssumedNoiseSigmaDn); the threshold given (min_modulation_dn),
// else ModulationThreshold at order_error_probability, capped at kMaxModulationThresholdFraction
// of full_scale_dn (`bounded` when the cap applied).
struct ModulationLimit {
  NoiseEstimate noise;
  double min_modulation_dn = 0;
  bool bounded = false;
};
ModulationLimit ChooseModulationThreshold(const PatternScheme& scheme,
                                          const std::vector<cv::Mat>& images,
                                          const DecodeOptions& options, double full_scale_dn);

enum class DecodeStatus { kSuccess, kNoValidPixels };

// Per-pixel outcome of the decoder (DecodeResult::reason): valid, or the first failing test in
// this order (the spatial check runs last).
enum class PixelReason : uint8_t {
  kValid = 0,
  kSaturated = 1,
  kUnderexposed = 2,
  kLowModulation = 3,
  kShadow = 4,
  kOrderAmbiguous = 5,
  kSpatial = 6,
};

// One exposure's part in a multi-exposure decode (DecodeExposures).
struct ExposureFigures {
  int64_t valid = 0;             // pixels valid in this exposure's own decode
  int64_t chosen = 0;            // pixels the combination took from this exposure
  int64_t orders_repaired = 0;   // fringe orders its own decode repaired (of every pixel)
  double min_modulation_dn = 0;  // its threshold
  double noise_sigma_dn = 0;     // its camera noise (given, estimated or assumed)
  // Its brightness relative to the main exposure (the one supplying most pixels; 1 for that):
  // median ratio of backgrounds over pixels valid in both; 0 when too few pixels are.
  double gain = 0;
};

struct DecodeSummary {
  DecodeStatus status = DecodeStatus::kSuccess;
  std::string message;
  int64_t pixels = 0;
  int64_t valid = 0;
  // Rejections by first failing reason, in this order.
  int64_t rejected_saturated = 0;
  int64_t rejected_underexposed = 0;
  int64_t rejected_low_modulation = 0;
  int64_t rejected_shadow = 0;
  int64_t rejected_order_ambiguous = 0;
  int64_t rejected_spatial = 0;    // spatial check failed and could not be repaired
  int64_t orders_repaired = 0;     // fringe-order errors detected by the spatial check and fixed
  double min_modulation_dn = 0;    // threshold used
  bool threshold_bounded = false;  // the automatic threshold hit kMaxModulationThresholdFraction
  double full_scale_dn = 0;        // full scale used (options or the image depth)
  NoiseEstimate noise;             // camera noise behind the automatic threshold
  double time_ms = 0;
  // Several exposures (DecodeExposures): one entry per exposure, in input order; empty for a
  // single stack. The figures above then describe the combination, pixel by pixel: valid and
  // the rejections (a pixel valid in no exposure counts under its reason in the unsaturated
  // exposure of highest modulation, or as saturated), orders_repaired the pixels of the
  // combination whose order the exposure they came from repaired (each pixel once); threshold /
  // noise / full scale those of the exposure that supplied most pixels.
  std::vector<ExposureFigures> exposures;

  double ValidFraction() const { return pixels ? static_cast<double>(valid) / pixels : 0.0; }
  std::string BriefReport() const;
};

// The summary as JSON (status, message, counts, noise, time): summary.json of `fringe decode`,
// the decode part of stereo::ToJson, the Python summary dict.
nlohmann::json ToJson(const DecodeSummary& summary);

// Many repaired or rejected fringe orders mean the scheme does not describe the capture (a
// wrong phase offset or Gray convention shifts every order decision): logs a warning naming
// `what` (the images) and the scheme when more than 1 % of the valid pixels needed either.
void WarnIfSchemeMismatch(const DecodeSummary& s, const std::string& scheme,
                          const std::string& what);

struct DecodeResult {
  cv::Mat absolute_phase;  // CV_32F, projector pixels along the fringe direction; NaN if invalid
  cv::Mat wrapped_phase;   // CV_32F, radians in [-pi, pi]: atan2 of set 0 (includes its offset)
  cv::Mat modulation;      // CV_32F, B of set 0 in DN
  cv::Mat background;      // CV_32F, A of set 0 in DN
  cv::Mat mask;            // CV_8U, 255 valid, 0 invalid
  cv::Mat reason;          // CV_8U, PixelReason per pixel
  cv::Mat exposure;        // CV_8U, index of the exposure a pixel came from (DecodeExposures;
                           // empty for a single stack; 255 where invalid)
  // Pixels (x = column, y = row) whose fringe order the spatial check repaired, in row-major
  // order: summary.orders_repaired of them.
  std::vector<cv::Point> repaired_px;
  DecodeSummary summary;
};

// images: the stack in the scheme's order, all CV_8UC1 or all CV_16UC1, same size. Throws
// fringe::Error for a wrong number of images, mixed sizes or types (naming the image index).
DecodeResult Decode(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
                    const DecodeOptions& options = {});
// Same, reusing result's buffers when they already have the right size (no allocation in a
// steady loop).
void Decode(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
            const DecodeOptions& options, DecodeResult* result);

// Most exposures DecodeExposures combines (the exposure index map is 8-bit).
constexpr int kMaxExposures = 16;

// Shiny parts need several exposures: short ones keep highlights unsaturated, long ones lift
// dark areas. stacks[e] is the whole stack at exposure e (same scheme, size and bit depth).
// Each is decoded alone (own noise estimate and threshold), then per pixel the exposure with the
// highest modulation B among those where the pixel is valid (so unsaturated in every
// phase-shift image) gives phase, modulation, background and wrapped phase. The camera's noise
// in DN does not grow with the exposure (read noise), so the highest B is the best phase
// (sigma_phi ~ sigma / B). The background and modulation maps are put on the main exposure's
// scale (divided by each exposure's gain, ExposureFigures), so texture and quality do not step
// where exposures meet; an exposure whose gain is unknown keeps its own DN. One stack: exactly
// Decode. Throws fringe::Error naming the exposure
// for a stack of another size or depth, none, or more than kMaxExposures.
DecodeResult DecodeExposures(const PatternScheme& scheme,
                             const std::vector<std::vector<cv::Mat>>& stacks,
                             const DecodeOptions& options = {});

// Standard deviation of set `set`'s wrapped phase (radians) for camera noise sigma_dn and
// modulation b_dn: sqrt(trace-based LS variance) = sqrt(2/N) sigma / B for equal shifts.
double WrappedPhaseSigma(const PatternScheme& scheme, int set, double sigma_dn, double b_dn);
// Standard deviation (projector px) of the absolute phase at camera noise sigma_dn and the same
// modulation b_dn in every set: the finest set's, or with whole_stack the inverse-variance
// combination of every set of a multi-frequency scheme (Gray-code schemes use set 0 alone).
double AbsolutePhaseSigmaPx(const PatternScheme& scheme, double sigma_dn, double b_dn,
                            bool whole_stack = true);
// Probability that some unwrapping step picks a wrong order at modulation b_dn (Gaussian noise).
double OrderErrorProbability(const PatternScheme& scheme, double sigma_dn, double b_dn);
// Smallest modulation with OrderErrorProbability <= probability, and at least the modulation
// that noise alone (no fringe: shadow, ambient light) exceeds with that probability,
// sigma sqrt(-ln(p) (Q11 + Q22)) for set 0 (B^2 of pure noise is sigma^2 (Q11 + Q22) / 2 times a
// chi^2 with 2 degrees of freedom). The coarsest heterodyne level is given at least kMinTopMargin
// of its period as margin beyond the projector span, the presets' margin (a beat of beats equal
// to the span has none, which would ask for an infinite modulation; pixels near the projector's
// edges are then left to the residual and spatial checks).
constexpr double kMinTopMargin = 0.1;
double ModulationThreshold(const PatternScheme& scheme, double sigma_dn, double probability);

// Fraction of valid pixels whose absolute phase differs from the median of the valid pixels in
// their 5x5 neighbourhood by more than fraction * period_px (period-edge jumps and wrong orders
// show up there). Pixels with fewer than 5 valid neighbours are not counted.
double JumpFraction(const cv::Mat& absolute_phase, const cv::Mat& mask, double period_px,
                    double fraction = 0.25);

}  // namespace fringe::phase
