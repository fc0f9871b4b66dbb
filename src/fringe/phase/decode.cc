#include "fringe/phase/decode.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>

#include "fringe/phase/gamma.h"
#include "fringe/phase/spatial_decode.h"
#include "fringe/util/error.h"
#include "fringe/util/log.h"
#include "fringe/util/timer.h"

namespace fringe::phase {
namespace {

using util::CheckOption;
using util::StrCat;

constexpr int kMaxSets = 8;
constexpr float kPiF = 3.14159265358979f;
constexpr float kInvTwoPiF = 0.159154943091895f;

// atan2 in float, branch free so that the row loops vectorise; max error 3e-7 rad (polynomial of
// Abramowitz & Stegun 4.4.49), far below any phase noise of 8- or 16-bit images.
inline float FastAtan2(float y, float x) {
  const float ax = std::fabs(x), ay = std::fabs(y);
  // Ternaries, not std::fmax/fmin: those keep NaN semantics and become library calls, which
  // stops vectorisation.
  const float mx = ax > ay ? ax : ay, mn = ax > ay ? ay : ax;
  const float a = mn / (mx + 1e-30f);
  const float s = a * a;
  float p = 0.0028662257f;
  p = p * s - 0.0161657367f;
  p = p * s + 0.0429096138f;
  p = p * s - 0.0752896400f;
  p = p * s + 0.1065626393f;
  p = p * s - 0.1420889944f;
  p = p * s + 0.1999355085f;
  p = p * s - 0.3333314528f;
  p = p * s + 1.0f;
  float r = p * a;
  r = ay > ax ? 1.57079637f - r : r;
  r = x < 0 ? 3.14159274f - r : r;
  return y < 0 ? -r : r;
}

// Round to nearest by the 1.5 * 2^23 trick (vectorises without SSE4.1); |x| < 2^22.
inline float RoundF(float x) { return (x + 12582912.0f) - 12582912.0f; }
// x in (-1, 1) -> [0, 1).
inline float Wrap01Small(float x) { return x < 0.0f ? x + 1.0f : x; }

// Row loops as functions with restrict-qualified pointers so that the compiler vectorises them
// without run-time alias checks; the heaviest ones are also compiled for AVX2 and picked at run
// time (GCC function multi-versioning), the default build staying baseline x86-64.
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define FRINGE_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define FRINGE_CLONES
#endif

// One phase-shift set over a row: least-squares A, B^2, wrapped phase psi and the fraction of
// the period (psi - offset) / 2 pi in [0, 1); maxi: raised to the largest value of the set's
// images (saturation over all sets in the same pass over the images). kN > 0
// fixes the number of steps at compile time (unrolled); kN == 0 uses n.
template <typename T, int kN>
FRINGE_CLONES void SetRow(int w, const T* const* rows, int n, const float* ca, const float* cc,
                          const float* cs, float offset, float* __restrict psi_out,
                          float* __restrict frac, float* __restrict bsq, float* __restrict a_out,
                          float* __restrict maxi) {
  const int steps = kN > 0 ? kN : n;
  for (int c = 0; c < w; ++c) {
    float sa = 0.0f, sc = 0.0f, ss = 0.0f;
    float m = maxi[c];
    for (int k = 0; k < steps; ++k) {
      const float x = static_cast<float>(rows[k][c]);
      m = x > m ? x : m;
      sa += ca[k] * x;
      sc += cc[k] * x;
      ss += cs[k] * x;
    }
    maxi[c] = m;
    const float psi = FastAtan2(ss, sc);
    bsq[c] = sc * sc + ss * ss;
    a_out[c] = sa;
    float t = (psi - offset) * kInvTwoPiF;
    t -= RoundF(t - 0.5f);
    frac[c] = t >= 1.0f ? t - 1.0f : t;
    psi_out[c] = psi;
  }
}

// out = in - other in cycles, wrapped to [0, 1): one heterodyne beat.
FRINGE_CLONES void BeatRow(int w, const float* __restrict a, const float* __restrict b,
                           float* __restrict out) {
  for (int c = 0; c < w; ++c) out[c] = Wrap01Small(a[c] - b[c]);
}

// The coarsest level (cycles of period pt) placed in the one period centred on `centre`, px.
FRINGE_CLONES void TopRow(int w, const float* __restrict top, float pt, float centre,
                          float* __restrict v) {
  for (int c = 0; c < w; ++c) {
    const float x = top[c] * pt;
    v[c] = x + pt * RoundF((centre - x) / pt);
  }
}

// One unwrapping step: the order of the finer level ff (cycles of period pf) from the coarser
// estimate v (px); resid keeps the largest rounding residual.
FRINGE_CLONES void DownRow(int w, const float* __restrict ff, float pf, float* __restrict v,
                           float* __restrict resid) {
  const float inv = 1.0f / pf;
  for (int c = 0; c < w; ++c) {
    const float t = v[c] * inv - ff[c];
    const float k = RoundF(t);
    const float e = std::fabs(t - k);
    resid[c] = resid[c] < e ? e : resid[c];
    v[c] = (ff[c] + k) * pf;
  }
}

// Whole stack: once the orders are known every set measures the same projector coordinate:
// each set's order from the finest estimate v, the sets combined weighted by their inverse
// variance, B_s^2 / (P_s^2 var_s) with var_s the set's phase variance per unit noise
// (weights[s] = 1 / (P_s^2 var_s)). Sets in the outer loop so that the pixels vectorise; the
// sums per pixel are taken in the same order as set by set.
FRINGE_CLONES void WholeStackRow(int w, int num_sets, const float* __restrict frac,
                                 const float* __restrict bsq, const float* periods,
                                 const float* weights, float* __restrict num, float* __restrict den,
                                 float* __restrict v) {
  for (int c = 0; c < w; ++c) num[c] = den[c] = 0.0f;
  for (int s = 0; s < num_sets; ++s) {
    const float ps = periods[s], sw = weights[s];
    const float* f = frac + static_cast<size_t>(s) * w;
    const float* b = bsq + static_cast<size_t>(s) * w;
    for (int c = 0; c < w; ++c) {
      const float us = (f[c] + RoundF(v[c] / ps - f[c])) * ps;
      const float ws = b[c] * sw;
      num[c] += ws * (us - v[c]);
      den[c] += ws;
    }
  }
  for (int c = 0; c < w; ++c) v[c] += den[c] > 0.0f ? num[c] / den[c] : 0.0f;
}

// Gray code: the mid-level of the white and dark frames.
template <typename T>
FRINGE_CLONES void MidLevelRow(int w, const T* __restrict white, const T* __restrict dark,
                               float* __restrict thr) {
  for (int c = 0; c < w; ++c) {
    thr[c] = 0.5f * (static_cast<float>(white[c]) + static_cast<float>(dark[c]));
  }
}

// An image row as floats: the threshold of a Gray bit whose inverse image was projected (the
// pair decides the bit, gray_inverted).
template <typename T>
void ToFloatRow(int w, const T* __restrict src, float* __restrict dst) {
  for (int c = 0; c < w; ++c) dst[c] = static_cast<float>(src[c]);
}

// One Gray bit: Gray -> binary (bin), appended to the code.
template <typename T>
FRINGE_CLONES void GrayBitRow(int w, const T* __restrict p, const float* __restrict thr,
                              int32_t* __restrict bin, int32_t* __restrict code) {
  for (int c = 0; c < w; ++c) {
    bin[c] ^= static_cast<float>(p[c]) > thr[c] ? 1 : 0;
    code[c] = (code[c] << 1) | bin[c];
  }
}

// The projector coordinate from the Gray code and set 0's fraction f; with the complementary
// bit (complementary != nullptr) the order near period edges comes from the half-period-shifted
// code, so there are no edge jumps.
template <typename T>
FRINGE_CLONES void GrayOrderRow(int w, const T* __restrict complementary,
                                const float* __restrict thr, const int32_t* __restrict bin,
                                const int32_t* __restrict code, const float* __restrict f, float p0,
                                float* __restrict v) {
  if (complementary == nullptr) {
    for (int c = 0; c < w; ++c) v[c] = (static_cast<float>(code[c]) + f[c]) * p0;
    return;
  }
  for (int c = 0; c < w; ++c) {
    const int last = bin[c] ^ (static_cast<float>(complementary[c]) > thr[c] ? 1 : 0);
    const int k2 = (((code[c] << 1) | last) + 1) >> 1;
    const int k = f[c] < 0.25f ? k2 : (f[c] > 0.75f ? k2 - 1 : code[c]);
    v[c] = (static_cast<float>(k) + f[c]) * p0;
  }
}

FRINGE_CLONES void SqrtRow(int w, const float* __restrict x, float* __restrict y) {
  for (int c = 0; c < w; ++c) y[c] = std::sqrt(x[c]);
}

// 1 where a valid pixel differs from a 4-neighbour by more than thr (rows up/dn may be the row
// itself at the image border).
FRINGE_CLONES void JumpScreenRow(int w, const float* __restrict a, const float* __restrict up,
                                 const float* __restrict dn, const uint8_t* __restrict m, float thr,
                                 uint8_t* __restrict flag) {
  auto jump = [&](int c, float l, float r) {
    const float x = a[c];
    // Bitwise | and &: no short-circuit branches, so the loop vectorises.
    const int j =
        static_cast<int>(std::fabs(l - x) > thr) | static_cast<int>(std::fabs(r - x) > thr) |
        static_cast<int>(std::fabs(up[c] - x) > thr) | static_cast<int>(std::fabs(dn[c] - x) > thr);
    return static_cast<uint8_t>(j & static_cast<int>(m[c] != 0));
  };
  if (w < 2) {
    for (int c = 0; c < w; ++c) flag[c] = jump(c, a[c], a[c]);
    return;
  }
  flag[0] = jump(0, a[0], a[1]);
  for (int c = 1; c + 1 < w; ++c) flag[c] = jump(c, a[c - 1], a[c + 1]);
  flag[w - 1] = jump(w - 1, a[w - 2], a[w - 1]);
}

// Number of pixels per reason code (vectorised compare-and-sum per code).
FRINGE_CLONES void CountReasons(int w, const uint8_t* __restrict reason,
                                std::array<int64_t, 6>* counts) {
  int64_t invalid = 0;
  for (int k = 1; k < 6; ++k) {
    int n = 0;
    for (int c = 0; c < w; ++c) n += reason[c] == k ? 1 : 0;
    (*counts)[k] = n;
    invalid += n;
  }
  (*counts)[0] = w - invalid;
}

// Pixel counts per PixelReason (valid first) into the summary's valid / rejected_* figures.
constexpr int kNumReasons = static_cast<int>(PixelReason::kSpatial) + 1;
void SetCounts(const std::array<int64_t, kNumReasons>& counts, DecodeSummary* sum) {
  sum->valid = counts[0];
  sum->rejected_saturated = counts[1];
  sum->rejected_underexposed = counts[2];
  sum->rejected_low_modulation = counts[3];
  sum->rejected_shadow = counts[4];
  sum->rejected_order_ambiguous = counts[5];
  sum->rejected_spatial = counts[6];
}

// Reason codes: 0 valid, 1 saturated, 2 under-exposed, 3 low modulation, 4 shadow, 5 ambiguous
// order (first failing test wins).
FRINGE_CLONES void ReasonRow(int w, const float* __restrict maxi, const float* __restrict a0,
                             const float* __restrict bsq, const float* __restrict resid,
                             float saturation, float min_background, float b_min_sq,
                             float min_ratio_sq, float max_residual, uint8_t* __restrict reason) {
  for (int c = 0; c < w; ++c) {
    int r = resid[c] > max_residual ? 5 : 0;
    r = bsq[c] < min_ratio_sq * a0[c] * a0[c] ? 4 : r;
    // The modulation test uses set 0 (the finest frequency has the lowest modulation under
    // defocus, and its N steps estimate B best).
    r = bsq[c] < b_min_sq ? 3 : r;
    r = a0[c] < min_background ? 2 : r;
    r = maxi[c] >= saturation ? 1 : r;
    reason[c] = static_cast<uint8_t>(r);
  }
}

FRINGE_CLONES void OutputRow(int w, const uint8_t* __restrict reason, const float* __restrict v,
                             float* __restrict abs, uint8_t* __restrict mask) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int c = 0; c < w; ++c) mask[c] = static_cast<uint8_t>(reason[c] == 0 ? 255 : 0);
  for (int c = 0; c < w; ++c) {
    const float x = v[c] - 0.5f;
    abs[c] = reason[c] == 0 ? x : nan;
  }
}

// Noise samples of one row of EstimateNoise: sample i takes the four pixels (row q, column
// 2 i + q dx), q = 0..3, rows[q * n + k] being image k's row for q; delta is their third
// difference per image, -v0 + 3 v1 - 3 v2 + v3 (exact integers), and rss[i] = |U^T delta|^2 its
// squared residual (basis: U, n x dims row-major) over its expectation per unit noise
// variance, 20 dims. ok[i] = 0 when any of the 4 n values is clipped (outside [1, hi]).
template <typename T>
FRINGE_CLONES void NoiseSampleRow(int count, int dx, int n, int dims, const void* const* rows,
                                  const double* basis, int hi, int32_t* __restrict delta,
                                  uint8_t* __restrict ok, double* __restrict proj,
                                  double* __restrict rss) {
  std::fill(ok, ok + count, uint8_t{1});
  std::fill(proj, proj + static_cast<size_t>(dims) * count, 0.0);
  for (int k = 0; k < n; ++k) {
    const T* p0 = static_cast<const T*>(rows[k]);
    const T* p1 = static_cast<const T*>(rows[n + k]) + dx;
    const T* p2 = static_cast<const T*>(rows[2 * n + k]) + 2 * dx;
    const T* p3 = static_cast<const T*>(rows[3 * n + k]) + 3 * dx;
    for (int i = 0; i < count; ++i) {
      const int a = p0[2 * i], b = p1[2 * i], c = p2[2 * i], d = p3[2 * i];
      const int lo = std::min(std::min(a, b), std::min(c, d));
      const int up = std::max(std::max(a, b), std::max(c, d));
      ok[i] &= static_cast<uint8_t>((lo >= 1) & (up <= hi));
      delta[i] = -a + 3 * b - 3 * c + d;
    }
    for (int j = 0; j < dims; ++j) {
      const double u = basis[static_cast<size_t>(k) * dims + j];
      double* t = proj + static_cast<size_t>(j) * count;
      for (int i = 0; i < count; ++i) t[i] += u * static_cast<double>(delta[i]);
    }
  }
  std::fill(rss, rss + count, 0.0);
  for (int j = 0; j < dims; ++j) {
    const double* t = proj + static_cast<size_t>(j) * count;
    for (int i = 0; i < count; ++i) rss[i] += t[i] * t[i];
  }
  const double scale = 20.0 * dims;  // E|R delta|^2 = 20 sigma^2 dims
  for (int i = 0; i < count; ++i) rss[i] /= scale;
}

// Block means of the valid samples of a row, kBlock consecutive valid samples each (a last
// partial block is dropped), appended to `means`. Sums are taken in sample order.
template <int kBlock>
FRINGE_CLONES void BlockMeans(int count, const double* __restrict value, const uint8_t* ok,
                              double* __restrict packed, double* __restrict sums,
                              std::vector<float>* means) {
  int m = 0;
  for (int i = 0; i < count; ++i) {  // branch-free compaction of the valid samples
    packed[m] = value[i];
    m += ok[i];
  }
  const int blocks = m / kBlock;
  for (int b = 0; b < blocks; ++b) sums[b] = 0.0;
  for (int j = 0; j < kBlock; ++j) {
    for (int b = 0; b < blocks; ++b) sums[b] += packed[b * kBlock + j];
  }
  for (int b = 0; b < blocks; ++b) means->push_back(static_cast<float>(sums[b] / kBlock));
}

// Least-squares coefficients: A = sum ca_k I_k, B cos(phi) = sum cc_k I_k,
// B sin(phi) = sum cs_k I_k for the model I_k = A + B cos(phi + shift_k).
struct SetCoefficients {
  std::vector<float> ca, cc, cs;
  cv::Matx33d cov;  // (M^T M)^-1: covariance of (A, a, b) per unit noise variance
};

SetCoefficients LeastSquaresCoefficients(const PhaseShiftSet& set) {
  const int n = set.steps;
  cv::Matx33d cov;
  const cv::Mat c = DemodulationMatrix(set, &cov);  // 3 x n
  SetCoefficients out;
  for (int k = 0; k < n; ++k) {
    out.ca.push_back(static_cast<float>(c.at<double>(0, k)));
    out.cc.push_back(static_cast<float>(c.at<double>(1, k)));
    out.cs.push_back(static_cast<float>(c.at<double>(2, k)));
  }
  out.cov = cov;
  return out;
}

// The heterodyne chain: level 0 holds the sets' phases (in cycles), level l element i is
// level l-1 element i minus element i+1. Each element is an integer combination of the sets'
// phases (weights) with its period.
struct ChainElement {
  double period = 0;
  std::array<double, kMaxSets> weights{};
};
using Chain = std::vector<std::vector<ChainElement>>;

Chain HeterodyneChain(const PatternScheme& s) {
  Chain chain(1);
  for (size_t i = 0; i < s.phase_sets.size(); ++i) {
    ChainElement e;
    e.period = s.phase_sets[i].period_px;
    e.weights[i] = 1.0;
    chain[0].push_back(e);
  }
  if (s.Method() == Unwrapping::kHierarchical) {
    // Hierarchical: level l is set l itself (no beats); each unwraps the next finer one.
    Chain levels;
    for (const ChainElement& e : chain[0]) levels.push_back({e});
    return levels;
  }
  if (s.Method() != Unwrapping::kHeterodyne) return chain;
  while (chain.back().size() > 1) {
    const auto& prev = chain.back();
    std::vector<ChainElement> next;
    for (size_t i = 0; i + 1 < prev.size(); ++i) {
      ChainElement e;
      e.period = prev[i].period * prev[i + 1].period / (prev[i + 1].period - prev[i].period);
      for (int k = 0; k < kMaxSets; ++k) e.weights[k] = prev[i].weights[k] - prev[i + 1].weights[k];
      next.push_back(e);
    }
    chain.push_back(next);
  }
  return chain;
}

// Standard deviations (in fine periods, at B = 1 and sigma = 1) of the rounding residual of each
// unwrapping step, and the margin (fraction of the fine period) an error must exceed.
struct UnwrapStepNoise {
  double sigma_per_unit = 0;
  double margin = 0.5;
};

double PhaseVariancePerUnit(const PatternScheme& s, int set) {
  // RMS over phi of var(phi) = (sin^2 Q11 + cos^2 Q22 - 2 sin cos Q12) / B^2.
  const auto c = LeastSquaresCoefficients(s.phase_sets[set]);
  return 0.5 * (c.cov(1, 1) + c.cov(2, 2));
}

std::vector<UnwrapStepNoise> StepNoise(const PatternScheme& s) {
  // Spatial unwrapping has no temporal step (its order errors are those of the flood fill and
  // the markers, spatial_decode.h).
  if (s.Method() == Unwrapping::kSpatial) return {};
  std::vector<double> var_cycles(s.phase_sets.size());
  for (size_t i = 0; i < s.phase_sets.size(); ++i) {
    var_cycles[i] = PhaseVariancePerUnit(s, static_cast<int>(i)) / (4.0 * M_PI * M_PI);
  }
  std::vector<UnwrapStepNoise> steps;
  if (s.gray_bits > 0) {
    // Complementary Gray code: the order is wrong when the phase errs by a quarter period.
    // Plain Gray code has no noise margin at period edges at all (its edge errors are left to
    // the spatial check); the same quarter period is used so that the threshold stays finite.
    UnwrapStepNoise st;
    st.sigma_per_unit = std::sqrt(var_cycles[0]);
    st.margin = 0.25;
    steps.push_back(st);
    return steps;
  }
  if (s.Method() == Unwrapping::kNumberTheoretic) {
    // Key j is f_0 c_j - f_j c_0 (cycles), rounded: wrong when its error exceeds half a unit.
    const NumberTheoreticTable t = MakeNumberTheoreticTable(s);
    for (size_t j = 1; j < s.phase_sets.size(); ++j) {
      const double f0 = t.counts[0], fj = t.counts[j];
      steps.push_back({std::sqrt(f0 * f0 * var_cycles[j] + fj * fj * var_cycles[0]), 0.5});
    }
    return steps;
  }
  const Chain chain = HeterodyneChain(s);
  {
    // The coarsest phase is placed in a window of one period centred on the projector: pixels
    // at the projector's edges are (L - span) / 2 from its wrap.
    const ChainElement& top = chain.back()[0];
    double var = 0;
    for (size_t k = 0; k < s.phase_sets.size(); ++k)
      var += top.weights[k] * top.weights[k] * var_cycles[k];
    if (chain.size() > 1) {
      steps.push_back(
          {std::sqrt(var), std::max(kMinTopMargin, 0.5 * (top.period - s.Span()) / top.period)});
    }
  }
  for (size_t l = chain.size() - 1; l >= 1; --l) {
    const ChainElement& coarse = chain[l][0];
    const ChainElement& fine = chain[l - 1][0];
    double var = 0;
    for (size_t k = 0; k < s.phase_sets.size(); ++k) {
      const double w = coarse.period / fine.period * coarse.weights[k] - fine.weights[k];
      var += w * w * var_cycles[k];
    }
    steps.push_back({std::sqrt(var), 0.5});
  }
  return steps;
}

double TwoSidedTail(double z) { return std::erfc(z / std::sqrt(2.0)); }

// Per-bit error probability of pure Gray code at modulation b_dn (see GrayCodeThreshold).
double GrayBitErrorProbability(const PatternScheme& scheme, double sigma_dn, double b_dn) {
  // A pair decides on P - N = +-2B with noise variance 2 sigma^2; a single image on I - (W + D)/2
  // = +-B with variance 1.5 sigma^2.
  const double z = scheme.gray_inverted ? 2.0 * b_dn / (std::sqrt(2.0) * sigma_dn)
                                        : b_dn / (std::sqrt(1.5) * sigma_dn);
  return scheme.gray_bits * 0.5 * std::erfc(z / std::sqrt(2.0));
}

// Modulation (half the white-dark or pair difference, DN) at which some bit of a pixel in the
// middle of a stripe is wrong with the given probability.
double GrayCodeThreshold(const PatternScheme& scheme, double sigma_dn, double probability) {
  double lo = 1e-3 * sigma_dn, hi = 1e6 * sigma_dn;
  for (int i = 0; i < 100; ++i) {
    const double mid = std::sqrt(lo * hi);
    (GrayBitErrorProbability(scheme, sigma_dn, mid) > probability ? lo : hi) = mid;
  }
  return hi;
}

template <typename T>
struct Kernel {
  const PatternScheme& scheme;
  const DecodeOptions& opt;
  const std::vector<cv::Mat>& images;
  const std::vector<SetCoefficients>& coeffs;
  const Chain& chain;
  const NumberTheoreticTable* nt;  // number-theoretic unwrapping, else nullptr
  bool hierarchical;               // levels are the sets themselves (no beats)
  const std::vector<std::unique_ptr<GammaPhaseCorrection>>& gamma;
  float b_min_sq, saturation, min_background, min_ratio_sq, max_residual;
  // Per set: period (px) and the whole-stack weight per unit B^2, 1 / (P^2 var per unit noise).
  std::array<float, kMaxSets> periods, stack_weight;
  DecodeResult* out;
  std::vector<std::array<int64_t, 6>>* row_counts;  // valid, sat, under, lowmod, shadow, order

  void operator()(const tbb::blocked_range<int>& range) const {
    const int w = images[0].cols;
    const int num_sets = static_cast<int>(scheme.phase_sets.size());
    const size_t wn = static_cast<size_t>(w) * num_sets;
    // Row buffers, allocated once per task: per set its phase fraction and B^2; the heterodyne
    // levels above level 0 (level l holds num_sets - l beat phases).
    std::vector<float> frac(wn), bsq(wn), tri(wn * num_sets / 2 + w);
    std::vector<float> v(w), resid(w), thr(w), num(w), den(w), psi_scratch(w), a_scratch(w);
    std::vector<float> maxi(w);
    std::vector<int32_t> code1(w), bin(w);
    std::vector<const T*> rows(images.size());
    for (int r = range.begin(); r < range.end(); ++r) {
      for (size_t i = 0; i < images.size(); ++i) rows[i] = images[i].ptr<T>(r);
      float* out_wrapped = out->wrapped_phase.ptr<float>(r);
      float* out_bg = out->background.ptr<float>(r);  // A of set 0, the tests' a0
      uint8_t* out_reason = out->reason.ptr<uint8_t>(r);

      // Least squares per set: phase (as a fraction of the period), B^2; A of set 0. Saturation:
      // the largest value over the phase-shift images, taken in the same pass (a saturated
      // Gray-code or white frame still gives an unambiguous bright decision, so it does not
      // reject a pixel).
      std::fill(maxi.begin(), maxi.end(), 0.0f);
      for (int s = 0; s < num_sets; ++s) {
        const int first = scheme.PhaseImageIndex(s);
        const int n = scheme.phase_sets[s].steps;
        const SetCoefficients& cf = coeffs[s];
        const float offset = static_cast<float>(scheme.phase_sets[s].phase_offset_rad);
        float* f = &frac[static_cast<size_t>(s) * w];
        float* b2 = &bsq[static_cast<size_t>(s) * w];
        float* psi = s == 0 ? out_wrapped : psi_scratch.data();
        float* av = s == 0 ? out_bg : a_scratch.data();
        const T* const* set_rows = &rows[first];
        auto* fn = n == 3 ? &SetRow<T, 3> : n == 4 ? &SetRow<T, 4> : &SetRow<T, 0>;
        fn(w, set_rows, n, cf.ca.data(), cf.cc.data(), cf.cs.data(), offset, psi, f, b2, av,
           maxi.data());
        if (gamma[s]) {
          for (int c = 0; c < w; ++c) {
            const float corrected = gamma[s]->Correct(psi[c]);
            psi[c] = corrected;
            float t = (corrected - offset) * kInvTwoPiF;
            t -= RoundF(t - 0.5f);
            f[c] = t >= 1.0f ? t - 1.0f : t;
          }
        }
      }
      SqrtRow(w, bsq.data(), out->modulation.ptr<float>(r));

      std::fill(resid.begin(), resid.end(), 0.0f);
      const float p0 = static_cast<float>(scheme.phase_sets[0].period_px);
      if (scheme.gray_bits > 0) {
        // Threshold: mid-level of white and dark frames when present, else the background A.
        const int wi = scheme.WhiteImageIndex(), di = scheme.DarkImageIndex();
        if (wi >= 0 && di >= 0) {
          MidLevelRow<T>(w, rows[wi], rows[di], thr.data());
        } else {
          std::copy(out_bg, out_bg + w, thr.begin());
        }
        std::fill(bin.begin(), bin.end(), 0);
        std::fill(code1.begin(), code1.end(), 0);
        for (int b = 0; b < scheme.gray_bits; ++b) {
          // Inverted images: the pair decides the bit (image brighter than its inverse).
          if (scheme.gray_inverted) ToFloatRow<T>(w, rows[scheme.GrayInverseIndex(b)], thr.data());
          GrayBitRow<T>(w, rows[scheme.GrayImageIndex(b)], thr.data(), bin.data(), code1.data());
        }
        const T* complementary =
            scheme.gray_complementary ? rows[scheme.GrayImageIndex(scheme.gray_bits)] : nullptr;
        if (complementary != nullptr && scheme.gray_inverted) {
          ToFloatRow<T>(w, rows[scheme.GrayInverseIndex(scheme.gray_bits)], thr.data());
        }
        GrayOrderRow<T>(w, complementary, thr.data(), bin.data(), code1.data(), frac.data(), p0,
                        v.data());
      } else {
        const int num_levels = static_cast<int>(chain.size());
        // lv[l]: element 0 of level l (wrapped phase in cycles), which the top-down pass needs.
        std::array<const float*, kMaxSets> lv{};
        if (nt != nullptr) {
          // Number-theoretic: the rounded keys f_0 c_j - f_j c_0 index the orders of set 0.
          const int n = num_sets;
          const float f0 = static_cast<float>(nt->counts[0]);
          int key[kMaxSets];
          for (int c = 0; c < w; ++c) {
            const float c0 = frac[c];
            float worst = 0.0f;
            for (int j = 1; j < n; ++j) {
              const float rj = f0 * frac[static_cast<size_t>(j) * w + c] -
                               static_cast<float>(nt->counts[j]) * c0;
              const float mj = RoundF(rj);
              worst = std::max(worst, std::fabs(rj - mj));
              key[j - 1] = static_cast<int>(mj);
            }
            const int k0 = nt->Lookup(key);
            resid[c] = k0 < 0 ? 1.0f : worst;
            v[c] = (c0 + static_cast<float>(std::max(k0, 0))) * p0;
          }
        } else {
          if (hierarchical) {
            for (int l = 0; l < num_levels; ++l) lv[l] = &frac[static_cast<size_t>(l) * w];
          } else {
            // Heterodyne: level 0 is the sets' phases, level l element i the beat of level l - 1
            // elements i and i + 1 (stored one level after the other in `tri`).
            const float* prev = frac.data();
            float* next = tri.data();
            lv[0] = prev;
            for (int l = 1; l < num_levels; ++l) {
              const int count = num_sets - l;
              for (int i = 0; i < count; ++i) {
                BeatRow(w, &prev[static_cast<size_t>(i) * w], &prev[static_cast<size_t>(i + 1) * w],
                        &next[static_cast<size_t>(i) * w]);
              }
              lv[l] = next;
              prev = next;
              next += static_cast<size_t>(count) * w;
            }
          }
          // Top: the coarsest period covers the span; take the representative nearest its
          // centre. Then each finer level's order from the coarser estimate.
          TopRow(w, lv[num_levels - 1], static_cast<float>(chain.back()[0].period),
                 0.5f * static_cast<float>(scheme.Span()), v.data());
          for (int l = num_levels - 2; l >= 0; --l) {
            DownRow(w, lv[l], static_cast<float>(chain[l][0].period), v.data(), resid.data());
          }
        }
        if (opt.whole_stack && num_sets > 1) {
          WholeStackRow(w, num_sets, frac.data(), bsq.data(), periods.data(), stack_weight.data(),
                        num.data(), den.data(), v.data());
        }
      }

      // Mask and outputs.
      ReasonRow(w, maxi.data(), out_bg, bsq.data(), resid.data(), saturation, min_background,
                b_min_sq, min_ratio_sq, max_residual, out_reason);
      OutputRow(w, out_reason, v.data(), out->absolute_phase.ptr<float>(r),
                out->mask.ptr<uint8_t>(r));
      std::array<int64_t, 6> counts{};
      CountReasons(w, out_reason, &counts);
      (*row_counts)[r] = counts;
    }
  }
};

float MedianOfValid(const cv::Mat& abs, const cv::Mat& mask, int r, int c, int radius, int* count) {
  float vals[25];
  int n = 0;
  for (int y = std::max(0, r - radius); y <= std::min(abs.rows - 1, r + radius); ++y) {
    const float* a = abs.ptr<float>(y);
    const uint8_t* m = mask.ptr<uint8_t>(y);
    for (int x = std::max(0, c - radius); x <= std::min(abs.cols - 1, c + radius); ++x) {
      if ((y != r || x != c) && m[x]) vals[n++] = a[x];
    }
  }
  *count = n;
  if (n == 0) return std::numeric_limits<float>::quiet_NaN();
  std::nth_element(vals, vals + n / 2, vals + n);
  return vals[n / 2];
}

}  // namespace

void DecodeOptions::Check() const {
  const char* o = "DecodeOptions";
  CheckOption(noise_sigma_dn >= 0 && std::isfinite(noise_sigma_dn), o, "noise_sigma_dn",
              noise_sigma_dn, "must be >= 0 (0 estimates it from the images)");
  CheckOption(order_error_probability > 0 && order_error_probability < 0.1, o,
              "order_error_probability", order_error_probability, "must be in (0, 0.1)");
  CheckOption(std::isfinite(min_modulation_dn), o, "min_modulation_dn", min_modulation_dn,
              "must be finite (<= 0 for automatic)");
  CheckOption(std::isfinite(full_scale_dn) && full_scale_dn <= 65535, o, "full_scale_dn",
              full_scale_dn, "must be <= 65535 (<= 0 for the image depth's)");
  CheckOption(std::isfinite(saturation_dn), o, "saturation_dn", saturation_dn,
              "must be finite (<= 0 for full scale)");
  CheckOption(min_background_fraction >= 0 && min_background_fraction < 1, o,
              "min_background_fraction", min_background_fraction, "must be in [0, 1)");
  CheckOption(min_modulation_ratio >= 0 && min_modulation_ratio < 1, o, "min_modulation_ratio",
              min_modulation_ratio, "must be in [0, 1)");
  CheckOption(max_order_residual > 0 && max_order_residual <= 0.5, o, "max_order_residual",
              max_order_residual, "must be in (0, 0.5]");
  CheckOption(spatial_check_fraction <= 1, o, "spatial_check_fraction", spatial_check_fraction,
              "must be <= 1 (<= 0 disables)");
  CheckOption(projector_gamma == 0 || (projector_gamma > 0 && projector_gamma <= 10), o,
              "projector_gamma", projector_gamma, "must be 0 (unknown) or in (0, 10]");
}

double DecodeOptions::ResidualGamma(const PatternScheme& scheme) const {
  if (projector_gamma <= 0 || scheme.gamma_precompensation <= 0) return 1.0;
  return projector_gamma / scheme.gamma_precompensation;
}

const char* ToString(NoiseSource s) {
  switch (s) {
    case NoiseSource::kGiven:
      return "given";
    case NoiseSource::kEstimated:
      return "estimated";
    case NoiseSource::kAssumed:
      return "assumed";
  }
  return "?";
}

std::string DecodeSummary::BriefReport() const {
  return StrCat(status == DecodeStatus::kSuccess ? "decoded" : "FAILED", ": ", valid, "/", pixels,
                " valid (", 100.0 * ValidFraction(), " %), rejected saturated ", rejected_saturated,
                ", under-exposed ", rejected_underexposed, ", low modulation ",
                rejected_low_modulation, " (B < ", min_modulation_dn, " DN",
                threshold_bounded ? ", bounded" : "", "; noise ", noise.sigma_dn, " DN ",
                ToString(noise.source), "), shadow ", rejected_shadow, ", ambiguous order ",
                rejected_order_ambiguous, ", spatial ", rejected_spatial, "; orders repaired ",
                orders_repaired, "; ", time_ms, " ms", message.empty() ? "" : "; ", message);
}

void WarnIfSchemeMismatch(const DecodeSummary& s, const std::string& scheme,
                          const std::string& what) {
  const double jumps = static_cast<double>(s.orders_repaired + s.rejected_spatial);
  const double base = static_cast<double>(s.valid + s.rejected_spatial);
  if (base > 0 && jumps > 0.01 * base) {
    util::LogWarning(util::StrCat(
        what, ": ", 100.0 * jumps / base,
        " % of the valid pixels needed a fringe-order repair or failed the order check; the "
        "phase offset or Gray-code convention of the scheme '",
        scheme,
        "' probably does not match the capture (docs/formats.md, \"Captures written by "
        "other tools\")"));
  }
}

nlohmann::json ToJson(const DecodeSummary& s) {
  nlohmann::json j = {
      {"status", s.status == DecodeStatus::kSuccess ? "success" : "no_valid_pixels"},
      {"message", s.message},
      {"pixels", s.pixels},
      {"valid", s.valid},
      {"valid_fraction", s.ValidFraction()},
      {"rejected_saturated", s.rejected_saturated},
      {"rejected_underexposed", s.rejected_underexposed},
      {"rejected_low_modulation", s.rejected_low_modulation},
      {"rejected_shadow", s.rejected_shadow},
      {"rejected_order_ambiguous", s.rejected_order_ambiguous},
      {"rejected_spatial", s.rejected_spatial},
      {"orders_repaired", s.orders_repaired},
      {"min_modulation_dn", s.min_modulation_dn},
      {"threshold_bounded", s.threshold_bounded},
      {"full_scale_dn", s.full_scale_dn},
      {"noise_sigma_dn", s.noise.sigma_dn},
      {"noise_source", ToString(s.noise.source)},
      {"noise_message", s.noise.message},
      {"time_ms", s.time_ms}};
  // Several exposures (DecodeExposures): what each contributed.
  if (!s.exposures.empty()) {
    nlohmann::json exposures = nlohmann::json::array();
    for (const ExposureFigures& e : s.exposures) {
      exposures.push_back({{"valid", e.valid},
                           {"chosen", e.chosen},
                           {"orders_repaired", e.orders_repaired},
                           {"min_modulation_dn", e.min_modulation_dn},
                           {"noise_sigma_dn", e.noise_sigma_dn},
                           {"gain", e.gain}});
    }
    j["exposures"] = exposures;
  }
  return j;
}

double WrappedPhaseSigma(const PatternScheme& scheme, int set, double sigma_dn, double b_dn) {
  return std::sqrt(PhaseVariancePerUnit(scheme, set)) * sigma_dn / b_dn;
}

double AbsolutePhaseSigmaPx(const PatternScheme& scheme, double sigma_dn, double b_dn,
                            bool whole_stack) {
  // Pure Gray code: the stripe's centre, uniformly off by up to half a stripe.
  if (scheme.phase_sets.empty()) return scheme.GrayPeriod() / std::sqrt(12.0);
  auto var_px = [&](size_t s) {
    const double p = scheme.phase_sets[s].period_px;
    return p * p / (4 * M_PI * M_PI) * PhaseVariancePerUnit(scheme, static_cast<int>(s)) *
           sigma_dn * sigma_dn / (b_dn * b_dn);
  };
  if (!whole_stack || scheme.gray_bits > 0 || scheme.phase_sets.size() == 1) {
    return std::sqrt(var_px(0));
  }
  double info = 0;
  for (size_t s = 0; s < scheme.phase_sets.size(); ++s) info += 1.0 / var_px(s);
  return std::sqrt(1.0 / info);
}

namespace {

double OrderErrorProbability(const std::vector<UnwrapStepNoise>& steps, double sigma_dn,
                             double b_dn) {
  double p = 0;
  for (const auto& st : steps) {
    p += TwoSidedTail(st.margin / (st.sigma_per_unit * sigma_dn / b_dn));
  }
  return std::min(p, 1.0);
}

}  // namespace

double OrderErrorProbability(const PatternScheme& scheme, double sigma_dn, double b_dn) {
  if (scheme.phase_sets.empty()) {
    return std::min(1.0, GrayBitErrorProbability(scheme, sigma_dn, b_dn));
  }
  return OrderErrorProbability(StepNoise(scheme), sigma_dn, b_dn);
}

double ModulationThreshold(const PatternScheme& scheme, double sigma_dn, double probability) {
  if (scheme.phase_sets.empty()) return GrayCodeThreshold(scheme, sigma_dn, probability);
  // OrderErrorProbability decreases with B: bisection on log B.
  const auto steps = StepNoise(scheme);
  double lo = 1e-3 * sigma_dn, hi = 1e6 * sigma_dn;
  for (int i = 0; i < 100; ++i) {
    const double mid = std::sqrt(lo * hi);
    (OrderErrorProbability(steps, sigma_dn, mid) > probability ? lo : hi) = mid;
  }
  const auto c = LeastSquaresCoefficients(scheme.phase_sets[0]);
  const double noise_only =
      sigma_dn * std::sqrt(-std::log(probability) * (c.cov(1, 1) + c.cov(2, 2)));
  return std::max(hi, noise_only);
}

ModulationLimit ChooseModulationThreshold(const PatternScheme& scheme,
                                          const std::vector<cv::Mat>& images,
                                          const DecodeOptions& options, double full_scale_dn) {
  ModulationLimit out;
  if (options.noise_sigma_dn > 0) {
    out.noise.sigma_dn = options.noise_sigma_dn;
    out.noise.source = NoiseSource::kGiven;
    out.noise.message = StrCat("camera noise ", out.noise.sigma_dn, " DN given");
  } else if (scheme.phase_sets.empty()) {
    out.noise.message = StrCat("camera noise ", kAssumedNoiseSigmaDn,
                               " DN assumed (pure Gray code); give --noise-sigma if known");
  } else if (options.min_modulation_dn <= 0) {
    out.noise = EstimateNoise(scheme, images, full_scale_dn);
  }
  out.min_modulation_dn = options.min_modulation_dn;
  if (out.min_modulation_dn <= 0) {
    out.min_modulation_dn =
        ModulationThreshold(scheme, out.noise.sigma_dn, options.order_error_probability);
    const double cap = kMaxModulationThresholdFraction * full_scale_dn;
    if (out.min_modulation_dn > cap) {
      out.min_modulation_dn = cap;
      out.bounded = true;
    }
  }
  return out;
}

NoiseEstimate EstimateNoise(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
                            double full_scale_dn) {
  constexpr int kNoiseBlock = 16;
  // At most this many sample rows, evenly spread: thousands of block means per direction fix the
  // median to a fraction of a percent, and the estimate then reads a fixed part of the images
  // instead of a quarter of every pixel (it runs before the decoder's pass over the stack).
  constexpr int kMaxNoiseRows = 128;
  NoiseEstimate est;
  int set = -1;
  for (size_t s = 0; s < scheme.phase_sets.size(); ++s) {
    if (scheme.phase_sets[s].steps >= 4 && scheme.phase_sets[s].flat_steps.empty()) {
      set = static_cast<int>(s);
      break;
    }
  }
  if (set < 0) {
    est.message = StrCat("no phase set has 4 or more steps (3-step sets leave no residual): ",
                         kAssumedNoiseSigmaDn, " DN assumed; give --noise-sigma if known");
    return est;
  }
  const auto shifts = scheme.phase_sets[set].Shifts();
  const int n = static_cast<int>(shifts.size());
  const int dims = n - 3;  // dimension of the residual space
  // The residual of a pixel is R v, R = I - M C the projection onto the orthogonal complement of
  // the model's columns (1, cos shift_k, -sin shift_k); U (n x dims, orthonormal columns, from
  // the SVD of M) spans it, so R = U U^T and |R x|^2 = |U^T x|^2.
  cv::Mat m(n, 3, CV_64F);
  for (int k = 0; k < n; ++k) {
    m.at<double>(k, 0) = 1.0;
    m.at<double>(k, 1) = std::cos(shifts[k]);
    m.at<double>(k, 2) = -std::sin(shifts[k]);
  }
  cv::Mat sv, left, vt;
  cv::SVD::compute(m, sv, left, vt, cv::SVD::FULL_UV);
  std::vector<double> basis(static_cast<size_t>(n) * dims);  // U row-major, U(k, j)
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < dims; ++j)
      basis[static_cast<size_t>(k) * dims + j] = left.at<double>(k, 3 + j);
  }
  const int first = scheme.PhaseImageIndex(set);
  const cv::Mat& im0 = images.at(first);
  const bool is16 = im0.depth() == CV_16U;
  // Unclipped values are in [1, hi]: v > 0 and v < full_scale_dn.
  const int hi = static_cast<int>(std::ceil(std::min(full_scale_dn, 65536.0))) - 1;
  // The residual also holds what the sinusoid model misses, above all projector-gamma harmonics
  // (a 4-step residual is the second harmonic: +-9 DN on the simulator's uncompensated patterns
  // against 1.5 DN of noise). Those follow the phase, which varies slowly from pixel to pixel,
  // while noise is independent per pixel: the third difference of the residual vectors of four
  // neighbours, -e(0) + 3 e(1) - 3 e(2) + e(3) (covariance 20 sigma^2 R, R the rank N - 3
  // projection), keeps the noise and cancels a smooth structure to third order (a harmonic
  // leaves amplitude * (k dphi)^3: 0.07 DN at 0.1 rad per pixel). It is taken along the rows and
  // along the columns, and the smaller estimate wins: structure only adds variance. The residual
  // being linear, that difference is R applied to the third difference of the intensities
  // (exact integers), so a sample costs N (N - 3) products (NoiseSampleRow).
  const int stride = 2 * ((im0.rows + 2 * kMaxNoiseRows - 1) / (2 * kMaxNoiseRows));
  std::vector<float> medians;
  int64_t samples = 0;
  for (const int dir : {0, 1}) {  // 0: along rows, 1: along columns
    const int dy = dir, dx = 1 - dir;
    // Samples at every 2nd column of every `stride`-th row (every 2nd on small images) whose four
    // pixels lie in the image.
    const int count = dir == 0 ? (im0.cols >= 4 ? (im0.cols - 4) / 2 + 1 : 0) : (im0.cols + 1) / 2;
    std::vector<std::vector<float>> per_row((im0.rows + stride - 1) / stride);
    tbb::parallel_for(
        tbb::blocked_range<int>(0, static_cast<int>(per_row.size()), 16),
        [&](const tbb::blocked_range<int>& range) {
          std::vector<int32_t> delta(count);
          std::vector<double> proj(static_cast<size_t>(dims) * count), rss(count), packed(count),
              sums(count / kNoiseBlock + 1);
          std::vector<uint8_t> ok(count);
          std::vector<const void*> rows(static_cast<size_t>(4) * n);
          for (int i = range.begin(); i < range.end(); ++i) {
            const int y = i * stride;
            if (y + 3 * dy >= im0.rows || count == 0) continue;
            for (int q = 0; q < 4; ++q) {
              for (int k = 0; k < n; ++k)
                rows[static_cast<size_t>(q) * n + k] = images[first + k].ptr(y + q * dy);
            }
            if (is16) {
              NoiseSampleRow<uint16_t>(count, dx, n, dims, rows.data(), basis.data(), hi,
                                       delta.data(), ok.data(), proj.data(), rss.data());
            } else {
              NoiseSampleRow<uint8_t>(count, dx, n, dims, rows.data(), basis.data(), hi,
                                      delta.data(), ok.data(), proj.data(), rss.data());
            }
            // Means over blocks of kNoiseBlock samples: 8-bit residuals take few distinct values,
            // and the median of block means is continuous and still robust to the odd defect.
            BlockMeans<kNoiseBlock>(count, rss.data(), ok.data(), packed.data(), sums.data(),
                                    &per_row[i]);
          }
        });
    std::vector<float> all;
    for (const auto& v : per_row) all.insert(all.end(), v.begin(), v.end());
    if (all.size() < 20) continue;
    const auto mid = all.begin() + static_cast<std::ptrdiff_t>(all.size() / 2);
    std::nth_element(all.begin(), mid, all.end());
    medians.push_back(*mid);
    samples = std::max(samples, static_cast<int64_t>(all.size()) * kNoiseBlock);
  }
  if (medians.empty()) {
    est.message = StrCat("too few unclipped pixels to estimate the noise from set ", set, ": ",
                         kAssumedNoiseSigmaDn, " DN assumed");
    return est;
  }
  const float median = *std::min_element(medians.begin(), medians.end());
  const int dof = kNoiseBlock * dims;
  const double chi_median = std::pow(1.0 - 2.0 / (9.0 * dof), 3.0);
  est.sigma_dn = std::sqrt(median / chi_median);
  est.source = NoiseSource::kEstimated;
  est.set = set;
  est.pixels = samples;
  est.message = StrCat("camera noise ", est.sigma_dn,
                       " DN estimated from the pixel-to-pixel variation of the least-squares "
                       "residual of phase set ",
                       set, " (", n, " steps, ", est.pixels, " pixels)");
  return est;
}

double JumpFraction(const cv::Mat& absolute_phase, const cv::Mat& mask, double period_px,
                    double fraction) {
  int64_t counted = 0, jumps = 0;
  const float thr = static_cast<float>(fraction * period_px);
  for (int r = 0; r < absolute_phase.rows; ++r) {
    const float* a = absolute_phase.ptr<float>(r);
    const uint8_t* m = mask.ptr<uint8_t>(r);
    for (int c = 0; c < absolute_phase.cols; ++c) {
      if (!m[c]) continue;
      int n = 0;
      const float med = MedianOfValid(absolute_phase, mask, r, c, 2, &n);
      if (n < 5) continue;
      ++counted;
      if (std::fabs(a[c] - med) > thr) ++jumps;
    }
  }
  return counted ? static_cast<double>(jumps) / counted : 0.0;
}

namespace {

// Why pixels were rejected, in words, when it is not the usual shadow and background: from the
// summary's counts, threshold and noise (one decode, or the combination of several exposures).
std::string RejectionNotes(const DecodeSummary& sum, bool threshold_given) {
  std::vector<std::string> notes;
  if (sum.valid == 0) notes.push_back("no pixel passed the quality mask");
  if (sum.threshold_bounded) {
    notes.push_back(StrCat("the automatic modulation threshold was bounded to ",
                           sum.min_modulation_dn, " DN (", kMaxModulationThresholdFraction,
                           " of full scale): the scheme's unwrapping margin is too small for "
                           "the noise"));
  }
  const int64_t rejected = sum.pixels - sum.valid;
  if (rejected > 0 && sum.rejected_low_modulation > rejected / 2) {
    notes.push_back(StrCat("most rejected pixels have a fringe modulation below ",
                           sum.min_modulation_dn, " DN (",
                           threshold_given ? "given" : sum.noise.message, ")"));
  }
  if (rejected > 0 && sum.rejected_saturated > rejected / 2) {
    notes.push_back(StrCat("most rejected pixels are saturated in a phase-shift image",
                           sum.exposures.empty() ? "" : " in every exposure",
                           ": lower the exposure or add ",
                           sum.exposures.empty() ? "one" : "a shorter one"));
  }
  std::string message;
  for (const auto& n : notes) message += (message.empty() ? "" : "; ") + n;
  return message;
}

}  // namespace

namespace {

// Pure Gray code (no phase-shift set; SLStudio's and OpenCV's Gray-code codecs): each bit from
// its image and inverse (bright where the image exceeds the inverse) or against the mid-level of
// the white and dark frames; the coordinate is the centre of the decoded stripe. Background and
// modulation come from the white and dark frames ((W + D) / 2 and (W - D) / 2), else from the
// pairs (mean level, smallest half-difference over the bits). A bright image may saturate
// without harm; there is no wrapped phase (0) and no fringe order for the spatial check to
// repair. Separate from the phase-shift kernel, which it shares nothing with.
template <typename T>
void DecodePureGrayRows(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
                        float b_min, float min_background, float min_ratio, DecodeResult* out,
                        std::vector<std::array<int64_t, 6>>* row_counts) {
  const int w = images[0].cols, bits = scheme.gray_bits;
  const int wi = scheme.WhiteImageIndex(), di = scheme.DarkImageIndex();
  const bool reference = wi >= 0 && di >= 0;
  const float period = static_cast<float>(scheme.GrayPeriod());
  const int span = scheme.Span();
  // Image of each bit and of its inverse (-1: thresholded against the reference frames).
  std::vector<int> image(bits), inverse(bits);
  for (int bit = 0; bit < bits; ++bit) {
    image[bit] = scheme.GrayImageIndex(bit);
    inverse[bit] = scheme.GrayInverseIndex(bit);
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, images[0].rows, 8), [&](const auto& range) {
    std::vector<const T*> rows(images.size());
    for (int r = range.begin(); r < range.end(); ++r) {
      for (size_t i = 0; i < images.size(); ++i) rows[i] = images[i].ptr<T>(r);
      float* abs = out->absolute_phase.ptr<float>(r);
      float* mod = out->modulation.ptr<float>(r);
      float* bg = out->background.ptr<float>(r);
      uint8_t* mask = out->mask.ptr<uint8_t>(r);
      uint8_t* reason = out->reason.ptr<uint8_t>(r);
      std::fill_n(out->wrapped_phase.ptr<float>(r), w, 0.0f);
      std::array<int64_t, 6> counts{};
      for (int c = 0; c < w; ++c) {
        float a = 0, b = std::numeric_limits<float>::max(), sum = 0;
        unsigned bin = 0, k = 0;
        const float thr =
            reference ? 0.5f * (static_cast<float>(rows[wi][c]) + static_cast<float>(rows[di][c]))
                      : 0.0f;
        for (int bit = 0; bit < bits; ++bit) {
          const float p = static_cast<float>(rows[image[bit]][c]);
          const float n = inverse[bit] >= 0 ? static_cast<float>(rows[inverse[bit]][c]) : thr;
          bin ^= p > n ? 1u : 0u;  // Gray -> binary, most significant first
          k = (k << 1) | bin;
          sum += p + n;
          b = std::min(b, 0.5f * std::fabs(p - n));
        }
        if (reference) {
          a = thr;
          b = 0.5f * (static_cast<float>(rows[wi][c]) - static_cast<float>(rows[di][c]));
        } else {
          a = sum / static_cast<float>(2 * bits);
        }
        PixelReason why = PixelReason::kValid;
        if (a < min_background) {
          why = PixelReason::kUnderexposed;
        } else if (b < b_min) {
          why = PixelReason::kLowModulation;
        } else if (b < min_ratio * a) {
          why = PixelReason::kShadow;
        } else if (static_cast<float>(k) * period >= static_cast<float>(span)) {
          why = PixelReason::kOrderAmbiguous;  // a code no stripe of the projector has
        }
        bg[c] = a;
        mod[c] = std::max(b, 0.0f);
        reason[c] = static_cast<uint8_t>(why);
        mask[c] = why == PixelReason::kValid ? 255 : 0;
        abs[c] = why == PixelReason::kValid ? (static_cast<float>(k) + 0.5f) * period - 0.5f
                                            : std::numeric_limits<float>::quiet_NaN();
        ++counts[static_cast<int>(why)];
      }
      (*row_counts)[r] = counts;
    }
  });
}

void DecodePureGray(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
                    const DecodeOptions& options, double full, util::Timer* timer,
                    DecodeResult* result) {
  const cv::Size size = images[0].size();
  const ModulationLimit limit = ChooseModulationThreshold(scheme, images, options, full);
  const NoiseEstimate& noise = limit.noise;
  const double b_min = limit.min_modulation_dn;
  const bool bounded = limit.bounded;
  for (cv::Mat* m : {&result->absolute_phase, &result->wrapped_phase, &result->modulation,
                     &result->background}) {
    m->create(size, CV_32F);
  }
  result->mask.create(size, CV_8U);
  result->reason.create(size, CV_8U);
  result->exposure.release();
  result->repaired_px.clear();
  std::vector<std::array<int64_t, 6>> row_counts(size.height);
  const float bmin = static_cast<float>(b_min);
  const float min_bg = static_cast<float>(options.min_background_fraction * full);
  const float ratio = static_cast<float>(options.min_modulation_ratio);
  if (images[0].depth() == CV_16U) {
    DecodePureGrayRows<uint16_t>(scheme, images, bmin, min_bg, ratio, result, &row_counts);
  } else {
    DecodePureGrayRows<uint8_t>(scheme, images, bmin, min_bg, ratio, result, &row_counts);
  }
  DecodeSummary& sum = result->summary;
  sum = DecodeSummary();
  sum.min_modulation_dn = b_min;
  sum.threshold_bounded = bounded;
  sum.full_scale_dn = full;
  sum.noise = noise;
  sum.pixels = static_cast<int64_t>(size.area());
  std::array<int64_t, kNumReasons> total{};
  for (const auto& rc : row_counts) {
    for (int i = 0; i < 6; ++i) total[i] += rc[i];
  }
  SetCounts(total, &sum);
  if (sum.valid == 0) sum.status = DecodeStatus::kNoValidPixels;
  sum.message = RejectionNotes(sum, options.min_modulation_dn > 0);
  sum.time_ms = timer->ElapsedMs();
}

// Gray code with phase sets and white and dark frames: a pixel whose white-dark contrast is too
// low for its Gray bits (half the difference below the Gray-code threshold at the camera noise,
// GrayCodeThreshold) is rejected as low modulation, whatever set 0's modulation says. Runs after
// the kernel on the pixels it found valid; row_counts are updated.
template <typename T>
void RejectByReferenceFrames(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
                             double b_min, DecodeResult* result,
                             std::vector<std::array<int64_t, 6>>* row_counts) {
  const cv::Mat& white = images[scheme.WhiteImageIndex()];
  const cv::Mat& dark = images[scheme.DarkImageIndex()];
  const float limit = static_cast<float>(2.0 * b_min);
  tbb::parallel_for(tbb::blocked_range<int>(0, white.rows, 16), [&](const auto& range) {
    for (int r = range.begin(); r < range.end(); ++r) {
      const T* wr = white.ptr<T>(r);
      const T* dr = dark.ptr<T>(r);
      uint8_t* reason = result->reason.ptr<uint8_t>(r);
      uint8_t* mask = result->mask.ptr<uint8_t>(r);
      float* abs = result->absolute_phase.ptr<float>(r);
      for (int c = 0; c < white.cols; ++c) {
        if (reason[c] != static_cast<uint8_t>(PixelReason::kValid)) continue;
        if (static_cast<float>(wr[c]) - static_cast<float>(dr[c]) >= limit) continue;
        reason[c] = static_cast<uint8_t>(PixelReason::kLowModulation);
        mask[c] = 0;
        abs[c] = std::numeric_limits<float>::quiet_NaN();
        --(*row_counts)[r][0];
        ++(*row_counts)[r][static_cast<int>(PixelReason::kLowModulation)];
      }
    }
  });
}

}  // namespace

void Decode(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
            const DecodeOptions& options, DecodeResult* result) {
  util::Timer timer;
  scheme.Check();
  options.Check();
  CheckOption(static_cast<int>(scheme.phase_sets.size()) <= kMaxSets, "PatternScheme", "phase_sets",
              scheme.phase_sets.size(), "at most 8 sets");
  if (static_cast<int>(images.size()) != scheme.NumImages()) {
    throw Error(StrCat("scheme '", scheme.name, "' needs ", scheme.NumImages(), " images, got ",
                       images.size()));
  }
  const auto names = scheme.ImageNames();
  for (size_t i = 0; i < images.size(); ++i) {
    if (images[i].empty()) throw Error(StrCat("image ", i, " (", names[i], ") is empty"));
    if (images[i].type() != CV_8UC1 && images[i].type() != CV_16UC1) {
      throw Error(StrCat("image ", i, " (", names[i], "): expected 8- or 16-bit single channel"));
    }
    if (images[i].type() != images[0].type()) {
      throw Error(StrCat("image ", i, " (", names[i], ") has a different bit depth than image 0"));
    }
    if (images[i].size() != images[0].size()) {
      throw Error(StrCat("image ", i, " (", names[i], ") is ", images[i].cols, "x", images[i].rows,
                         ", image 0 is ", images[0].cols, "x", images[0].rows));
    }
  }
  const cv::Size size = images[0].size();
  const bool is16 = images[0].depth() == CV_16U;
  const double container_full = is16 ? 65535.0 : 255.0;
  if (options.full_scale_dn > container_full) {
    throw Error(StrCat("full scale ", options.full_scale_dn, " DN exceeds what the ", is16 ? 16 : 8,
                       "-bit images hold (", container_full, "): check the bit depth"));
  }
  const double full = options.full_scale_dn > 0 ? options.full_scale_dn : container_full;
  if (scheme.phase_sets.empty()) {
    DecodePureGray(scheme, images, options, full, &timer, result);
    return;
  }
  if (scheme.Method() == Unwrapping::kSpatial) {
    DecodeSpatial(scheme, images, options, full, result);
    result->summary.time_ms = timer.ElapsedMs();
    return;
  }

  std::vector<SetCoefficients> coeffs;
  std::vector<std::unique_ptr<GammaPhaseCorrection>> gamma(scheme.phase_sets.size());
  // A relative tolerance: a pre-compensation written with a few digits still counts as exact.
  const double residual_gamma = options.ResidualGamma(scheme);
  for (size_t s = 0; s < scheme.phase_sets.size(); ++s) {
    coeffs.push_back(LeastSquaresCoefficients(scheme.phase_sets[s]));
    if (std::abs(residual_gamma - 1.0) > 1e-6) {
      CheckOption(scheme.phase_sets[s].flat_steps.empty(), "DecodeOptions", "projector_gamma",
                  options.projector_gamma,
                  "cannot correct a set with flat steps (give 0, or pre-compensate the patterns)");
      gamma[s] = std::make_unique<GammaPhaseCorrection>(scheme.phase_sets[s].Shifts(),
                                                        scheme.intensity_mean,
                                                        scheme.intensity_amplitude, residual_gamma);
    }
  }
  const Chain chain = HeterodyneChain(scheme);
  std::optional<NumberTheoreticTable> nt;
  if (scheme.Method() == Unwrapping::kNumberTheoretic) nt = MakeNumberTheoreticTable(scheme);
  const ModulationLimit limit = ChooseModulationThreshold(scheme, images, options, full);
  const NoiseEstimate& noise = limit.noise;
  const double b_min = limit.min_modulation_dn;
  const bool bounded = limit.bounded;

  result->absolute_phase.create(size, CV_32F);
  result->wrapped_phase.create(size, CV_32F);
  result->modulation.create(size, CV_32F);
  result->background.create(size, CV_32F);
  result->mask.create(size, CV_8U);
  result->reason.create(size, CV_8U);
  result->exposure.release();
  result->repaired_px.clear();
  std::vector<std::array<int64_t, 6>> row_counts(size.height);

  std::array<float, kMaxSets> periods{}, stack_weight{};
  for (size_t i = 0; i < scheme.phase_sets.size(); ++i) {
    const double p = scheme.phase_sets[i].period_px;
    periods[i] = static_cast<float>(p);
    stack_weight[i] =
        static_cast<float>(1.0 / (p * p * PhaseVariancePerUnit(scheme, static_cast<int>(i))));
  }
  auto run = [&](auto tag) {
    using T = decltype(tag);
    Kernel<T> k{scheme,
                options,
                images,
                coeffs,
                chain,
                nt ? &*nt : nullptr,
                scheme.Method() == Unwrapping::kHierarchical,
                gamma,
                static_cast<float>(b_min * b_min),
                static_cast<float>(options.saturation_dn > 0 ? options.saturation_dn : full),
                static_cast<float>(options.min_background_fraction * full),
                static_cast<float>(options.min_modulation_ratio * options.min_modulation_ratio),
                static_cast<float>(options.max_order_residual),
                periods,
                stack_weight,
                result,
                &row_counts};
    tbb::parallel_for(tbb::blocked_range<int>(0, size.height, 8), k);
  };
  if (is16) {
    run(uint16_t{});
  } else {
    run(uint8_t{});
  }
  if (scheme.gray_bits > 0 && scheme.white_frame && scheme.dark_frame) {
    const double gray_min =
        GrayCodeThreshold(scheme, noise.sigma_dn, options.order_error_probability);
    if (is16) {
      RejectByReferenceFrames<uint16_t>(scheme, images, gray_min, result, &row_counts);
    } else {
      RejectByReferenceFrames<uint8_t>(scheme, images, gray_min, result, &row_counts);
    }
  }

  DecodeSummary& sum = result->summary;
  sum = DecodeSummary();
  sum.min_modulation_dn = b_min;
  sum.threshold_bounded = bounded;
  sum.full_scale_dn = full;
  sum.noise = noise;
  sum.pixels = static_cast<int64_t>(size.area());
  std::array<int64_t, kNumReasons> total{};  // the spatial check's rejections come below
  for (const auto& rc : row_counts) {
    for (int i = 0; i < 6; ++i) total[i] += rc[i];
  }
  SetCounts(total, &sum);

  // Spatial fringe-order check. Decisions are taken on the unmodified map (per row, in
  // parallel) and applied afterwards, so the result does not depend on the thread count.
  if (options.spatial_check_fraction > 0) {
    const float p0 = static_cast<float>(scheme.phase_sets[0].period_px);
    const float thr = static_cast<float>(options.spatial_check_fraction) * p0;
    cv::Mat& abs = result->absolute_phase;
    const cv::Mat& mask = result->mask;
    std::vector<std::vector<std::pair<int, float>>> fixes(size.height);
    tbb::enumerable_thread_specific<std::vector<uint8_t>> flags(
        std::vector<uint8_t>(static_cast<size_t>(size.width)));
    tbb::parallel_for(tbb::blocked_range<int>(0, size.height, 16), [&](const auto& range) {
      for (int r = range.begin(); r < range.end(); ++r) {
        const float* a = abs.ptr<float>(r);
        const uint8_t* m = mask.ptr<uint8_t>(r);
        const float* up = abs.ptr<float>(r > 0 ? r - 1 : r);
        const float* dn = abs.ptr<float>(r + 1 < size.height ? r + 1 : r);
        // Cheap, vectorised screen: a jump to any 4-neighbour (NaN neighbours compare false).
        JumpScreenRow(size.width, a, up, dn, m, thr, flags.local().data());
        const uint8_t* flag = flags.local().data();
        for (int c = 0; c < size.width; ++c) {
          if (!flag[c]) continue;
          const float x = a[c];
          int n = 0;
          const float med = MedianOfValid(abs, mask, r, c, 2, &n);
          if (n < 5 || std::fabs(x - med) <= thr) continue;
          float fixed = std::numeric_limits<float>::quiet_NaN();
          if (options.repair_orders) {
            const float shifted = x + p0 * std::round((med - x) / p0);
            if (std::fabs(shifted - med) <= thr) fixed = shifted;
          }
          fixes[r].emplace_back(c, fixed);
        }
      }
    });
    for (int r = 0; r < size.height; ++r) {
      for (const auto& [c, value] : fixes[r]) {
        abs.at<float>(r, c) = value;
        if (std::isnan(value)) {
          result->mask.at<uint8_t>(r, c) = 0;
          result->reason.at<uint8_t>(r, c) = static_cast<uint8_t>(PixelReason::kSpatial);
          ++sum.rejected_spatial;
          --sum.valid;
        } else {
          ++sum.orders_repaired;
          result->repaired_px.emplace_back(c, r);
        }
      }
    }
  }
  if (sum.valid == 0) sum.status = DecodeStatus::kNoValidPixels;
  sum.message = RejectionNotes(sum, options.min_modulation_dn > 0);
  sum.time_ms = timer.ElapsedMs();
}

DecodeResult Decode(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
                    const DecodeOptions& options) {
  DecodeResult r;
  Decode(scheme, images, options, &r);
  return r;
}

DecodeResult DecodeExposures(const PatternScheme& scheme,
                             const std::vector<std::vector<cv::Mat>>& stacks,
                             const DecodeOptions& options) {
  if (stacks.empty()) throw Error("DecodeExposures: no exposure given");
  if (stacks.size() > static_cast<size_t>(kMaxExposures)) {
    throw Error(StrCat("DecodeExposures: ", stacks.size(), " exposures, at most ", kMaxExposures));
  }
  if (stacks.size() == 1) return Decode(scheme, stacks[0], options);
  util::Timer timer;
  for (size_t e = 1; e < stacks.size(); ++e) {
    if (stacks[e].empty() || stacks[0].empty()) continue;  // Decode says what is missing
    if (stacks[e][0].size() != stacks[0][0].size() || stacks[e][0].type() != stacks[0][0].type()) {
      throw Error(StrCat("exposure ", e, ": images are ", stacks[e][0].cols, "x", stacks[e][0].rows,
                         " of depth ", stacks[e][0].elemSize() * 8, " bits, exposure 0's are ",
                         stacks[0][0].cols, "x", stacks[0][0].rows, " of ",
                         stacks[0][0].elemSize() * 8, " bits"));
    }
  }
  std::vector<DecodeResult> each(stacks.size());
  for (size_t e = 0; e < stacks.size(); ++e) {
    try {
      Decode(scheme, stacks[e], options, &each[e]);
    } catch (const Error& err) {
      throw Error(StrCat("exposure ", e, ": ", err.what()));
    }
  }
  DecodeResult out;
  out.absolute_phase = each[0].absolute_phase.clone();
  out.wrapped_phase = each[0].wrapped_phase.clone();
  out.modulation = each[0].modulation.clone();
  out.background = each[0].background.clone();
  out.mask = each[0].mask.clone();
  out.reason = each[0].reason.clone();
  const cv::Size size = out.mask.size();
  out.exposure.create(size, CV_8U);
  constexpr uint8_t kNone = 255;
  const int n = static_cast<int>(stacks.size());
  // Per pixel, independent of the others: rows in parallel, the same result for any thread count.
  tbb::parallel_for(tbb::blocked_range<int>(0, size.height, 16), [&](const auto& range) {
    for (int r = range.begin(); r < range.end(); ++r) {
      uint8_t* chosen = out.exposure.ptr<uint8_t>(r);
      uint8_t* reason = out.reason.ptr<uint8_t>(r);
      for (int c = 0; c < size.width; ++c) {
        int best = -1, unsaturated = -1;
        float best_b = -1, unsaturated_b = -1;
        for (int e = 0; e < n; ++e) {
          const uint8_t why = each[e].reason.ptr<uint8_t>(r)[c];
          const float b = each[e].modulation.ptr<float>(r)[c];
          if (why == static_cast<uint8_t>(PixelReason::kValid) && b > best_b) {
            best = e;
            best_b = b;
          }
          if (why != static_cast<uint8_t>(PixelReason::kSaturated) && b > unsaturated_b) {
            unsaturated = e;
            unsaturated_b = b;
          }
        }
        const int from = best >= 0 ? best : (unsaturated >= 0 ? unsaturated : 0);
        chosen[c] = best >= 0 ? static_cast<uint8_t>(best) : kNone;
        reason[c] = best >= 0 ? static_cast<uint8_t>(PixelReason::kValid)
                              : (unsaturated >= 0 ? each[unsaturated].reason.ptr<uint8_t>(r)[c]
                                                  : static_cast<uint8_t>(PixelReason::kSaturated));
        if (from == 0) continue;
        const DecodeResult& d = each[from];
        out.absolute_phase.ptr<float>(r)[c] = d.absolute_phase.ptr<float>(r)[c];
        out.wrapped_phase.ptr<float>(r)[c] = d.wrapped_phase.ptr<float>(r)[c];
        out.modulation.ptr<float>(r)[c] = d.modulation.ptr<float>(r)[c];
        out.background.ptr<float>(r)[c] = d.background.ptr<float>(r)[c];
        out.mask.ptr<uint8_t>(r)[c] = d.mask.ptr<uint8_t>(r)[c];
      }
    }
  });
  // Invalid pixels carry NaN phase whichever exposure they came from (the mask rules).
  out.absolute_phase.setTo(std::numeric_limits<float>::quiet_NaN(), out.mask == 0);

  DecodeSummary& sum = out.summary;
  sum.pixels = static_cast<int64_t>(size.area());
  std::array<int64_t, kNumReasons> counts{};
  for (int r = 0; r < size.height; ++r) {
    const uint8_t* reason = out.reason.ptr<uint8_t>(r);
    for (int c = 0; c < size.width; ++c) ++counts[std::min<int>(reason[c], kNumReasons - 1)];
  }
  SetCounts(counts, &sum);
  std::vector<int64_t> supplied(stacks.size(), 0);
  for (int r = 0; r < size.height; ++r) {
    const uint8_t* chosen = out.exposure.ptr<uint8_t>(r);
    for (int c = 0; c < size.width; ++c) {
      if (chosen[c] != kNone) ++supplied[chosen[c]];
    }
  }
  size_t main = 0;
  for (size_t e = 0; e < stacks.size(); ++e) {
    const DecodeSummary& s = each[e].summary;
    sum.exposures.push_back(
        {s.valid, supplied[e], s.orders_repaired, s.min_modulation_dn, s.noise.sigma_dn});
    if (supplied[e] > supplied[main]) main = e;
  }
  // Repaired orders of the combination: a pixel counts when the exposure that supplied it
  // repaired it (not when another exposure did, and once however many did), so that the
  // scheme-mismatch warning compares like with like (repairs over the combination's pixels).
  for (size_t e = 0; e < stacks.size(); ++e) {
    for (const cv::Point& p : each[e].repaired_px) {
      if (out.exposure.at<uint8_t>(p) == static_cast<uint8_t>(e)) out.repaired_px.push_back(p);
    }
  }
  std::sort(
      out.repaired_px.begin(), out.repaired_px.end(),
      [](const cv::Point& a, const cv::Point& b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
  sum.orders_repaired = static_cast<int64_t>(out.repaired_px.size());
  // Gains relative to the main exposure (a linear sensor's exposure ratio), from every 2nd pixel
  // of every 2nd row valid in both; then the maps of other exposures' pixels on its scale.
  constexpr size_t kMinGainPixels = 100;
  std::vector<double> gain(stacks.size(), 0.0);
  gain[main] = 1.0;
  for (size_t e = 0; e < stacks.size(); ++e) {
    if (e == main) continue;
    std::vector<float> ratios;
    for (int r = 0; r < size.height; r += 2) {
      const uint8_t* re = each[e].reason.ptr<uint8_t>(r);
      const uint8_t* rm = each[main].reason.ptr<uint8_t>(r);
      const float* ae = each[e].background.ptr<float>(r);
      const float* am = each[main].background.ptr<float>(r);
      for (int c = 0; c < size.width; c += 2) {
        if (re[c] == 0 && rm[c] == 0 && am[c] > 0) ratios.push_back(ae[c] / am[c]);
      }
    }
    if (ratios.size() < kMinGainPixels) continue;
    std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
    gain[e] = ratios[ratios.size() / 2];
  }
  for (int r = 0; r < size.height; ++r) {
    const uint8_t* chosen = out.exposure.ptr<uint8_t>(r);
    float* bg = out.background.ptr<float>(r);
    float* mod = out.modulation.ptr<float>(r);
    for (int c = 0; c < size.width; ++c) {
      if (chosen[c] == kNone || !(gain[chosen[c]] > 0)) continue;
      bg[c] = static_cast<float>(bg[c] / gain[chosen[c]]);
      mod[c] = static_cast<float>(mod[c] / gain[chosen[c]]);
    }
  }
  for (size_t e = 0; e < stacks.size(); ++e) sum.exposures[e].gain = gain[e];
  sum.min_modulation_dn = each[main].summary.min_modulation_dn;
  sum.threshold_bounded = each[main].summary.threshold_bounded;
  sum.full_scale_dn = each[main].summary.full_scale_dn;
  sum.noise = each[main].summary.noise;
  std::string parts;
  for (size_t e = 0; e < stacks.size(); ++e) {
    parts += StrCat(e ? ", " : "", "e", e, " valid ", sum.exposures[e].valid, " chosen ",
                    sum.exposures[e].chosen, " gain ",
                    gain[e] > 0 ? StrCat(gain[e]) : std::string("unknown"));
  }
  if (sum.valid == 0) sum.status = DecodeStatus::kNoValidPixels;
  // The notes on the combination's counts (e.g. saturated in every exposure), then what each
  // exposure gave.
  const std::string notes = RejectionNotes(sum, options.min_modulation_dn > 0);
  sum.message =
      StrCat(notes, notes.empty() ? "" : "; ", stacks.size(), " exposures combined (", parts, ")");
  sum.time_ms = timer.ElapsedMs();
  return out;
}

cv::Mat DemodulationMatrix(const std::vector<double>& shifts, cv::Matx33d* cov) {
  PhaseShiftSet set;
  set.steps = static_cast<int>(shifts.size());
  set.shifts_rad = shifts;
  return DemodulationMatrix(set, cov);
}

cv::Mat DemodulationMatrix(const PhaseShiftSet& set, cv::Matx33d* cov) {
  const auto shifts = set.Shifts();
  const int n = static_cast<int>(shifts.size());
  cv::Mat m(n, 3, CV_64F);
  for (int k = 0; k < n; ++k) {
    // A flat step (no fringe) measures the background alone.
    const bool flat = set.IsFlat(k);
    m.at<double>(k, 0) = 1.0;
    m.at<double>(k, 1) = flat ? 0.0 : std::cos(shifts[k]);
    m.at<double>(k, 2) = flat ? 0.0 : -std::sin(shifts[k]);
  }
  const cv::Mat q = (m.t() * m).inv(cv::DECOMP_SVD);
  if (cov) *cov = cv::Matx33d(q.ptr<double>());
  return q * m.t();
}

}  // namespace fringe::phase
