#include "fringe/phase/pattern_scheme.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::phase {
namespace {

using nlohmann::json;
using util::CheckOption;
using util::StrCat;

constexpr double kTwoPi = 2.0 * M_PI;

// Beat period of two phase sets with periods p < q (the period of phi_p - phi_q).
double BeatPeriod(double p, double q) { return p * q / (q - p); }

// Smallest eigenvalue over largest of M^T M for the design rows [1, cos d, -sin d] ([1, 0, 0]
// for a flat step): the least-squares demodulation is well posed when this is not tiny.
double ShiftConditioning(const PhaseShiftSet& set) {
  cv::Matx33d m = cv::Matx33d::zeros();
  const auto shifts = set.Shifts();
  for (size_t k = 0; k < shifts.size(); ++k) {
    const double d = shifts[k];
    const bool flat = set.IsFlat(static_cast<int>(k));
    const cv::Vec3d r(1.0, flat ? 0.0 : std::cos(d), flat ? 0.0 : -std::sin(d));
    m += r * r.t();
  }
  cv::Mat evals;
  cv::eigen(cv::Mat(m), evals);
  return evals.at<double>(2) / evals.at<double>(0);
}

// Relative tolerance of the coarsest period against the projector span: periods given as span /
// count round in the last digits, and tools that compute in single precision (OpenCV's period
// 1 / float(1 / P)) fall short of the span by up to half a float ulp (6e-8).
constexpr double kSpanTolerance = 1e-7;

unsigned Gray(unsigned k) { return k ^ (k >> 1); }

}  // namespace

std::string DirectionName(FringeDirection d) {
  return d == FringeDirection::kVertical ? "vertical" : "horizontal";
}

std::vector<double> PhaseShiftSet::Shifts() const {
  if (!shifts_rad.empty()) return shifts_rad;
  std::vector<double> s(std::max(steps, 0));
  for (int k = 0; k < steps; ++k) s[k] = kTwoPi * k / steps;
  return s;
}

bool PhaseShiftSet::IsFlat(int step) const {
  return std::find(flat_steps.begin(), flat_steps.end(), step) != flat_steps.end();
}

int PatternScheme::NumPhaseImages() const {
  int n = 0;
  for (const auto& s : phase_sets) n += s.steps;
  return n;
}

int PatternScheme::NumImages() const {
  return NumPhaseImages() + NumGrayImages() + NumReferenceImages();
}

int PatternScheme::PhaseImageIndex(int set) const {
  int n = reference_frames_first ? NumReferenceImages() : 0;
  for (int s = 0; s < set; ++s) n += phase_sets[s].steps;
  return n;
}

int PatternScheme::GrayImageIndex(int bit) const {
  return (reference_frames_first ? NumReferenceImages() : 0) + NumPhaseImages() +
         (gray_inverted ? 2 * bit : bit);
}

int PatternScheme::GrayInverseIndex(int bit) const {
  return gray_inverted ? GrayImageIndex(bit) + 1 : -1;
}

int PatternScheme::WhiteImageIndex() const {
  if (!white_frame) return -1;
  return reference_frames_first ? 0 : NumPhaseImages() + NumGrayImages();
}

int PatternScheme::DarkImageIndex() const {
  if (!dark_frame) return -1;
  return (reference_frames_first ? 0 : NumPhaseImages() + NumGrayImages()) + (white_frame ? 1 : 0);
}

namespace {

// A value on the byte scale [0, 255] to a byte, as `q` says.
uint8_t QuantizeValue(Quantization q, double x) {
  x = std::clamp(x, 0.0, 255.0);
  switch (q) {
    case Quantization::kFloor:
      return static_cast<uint8_t>(std::floor(x));
    case Quantization::kRoundHalfEven:
      return static_cast<uint8_t>(std::nearbyint(x));  // default rounding mode: ties to even
    case Quantization::kRound:
      break;
  }
  return static_cast<uint8_t>(std::lround(x));
}

}  // namespace

uint8_t PatternScheme::Quantize(double linear, double gamma) const {
  const double lin = std::clamp(linear, 0.0, 1.0);
  return QuantizeValue(quantization, 255.0 * (gamma == 1.0 ? lin : std::pow(lin, 1.0 / gamma)));
}

const char* QuantizationName(Quantization q) {
  switch (q) {
    case Quantization::kRound:
      return "round";
    case Quantization::kRoundHalfEven:
      return "round-half-even";
    case Quantization::kFloor:
      return "floor";
  }
  return "?";
}

const char* ArithmeticName(Arithmetic a) {
  switch (a) {
    case Arithmetic::kDouble:
      return "double";
    case Arithmetic::kFloat32:
      return "float32";
    case Arithmetic::kFloat32Wrapped:
      return "float32-wrapped";
  }
  return "?";
}

const char* PhaseRetrievalName(PhaseRetrieval r) {
  switch (r) {
    case PhaseRetrieval::kLeastSquares:
      return "least-squares";
    case PhaseRetrieval::kFtp:
      return "ftp";
    case PhaseRetrieval::kFaps:
      return "faps";
  }
  return "?";
}

std::vector<MarkerPosition> MarkerPositions(const PatternScheme& s) {
  std::vector<MarkerPosition> out;
  if (!s.markers.Present() || s.phase_sets.empty()) return out;
  // sinusoidalpattern.cpp, SinusoidalPattern::generate with setMarkers: integer arithmetic
  // throughout, as there.
  const int span = s.Span();
  const int side =
      s.direction == FringeDirection::kVertical ? s.projector_height : s.projector_width;
  const int period = s.markers.Period(span);
  const int n = s.markers.Group();
  const int m = s.markers.spacing_px;
  if (n <= 0 || period <= 0) return out;
  const int mn_ratio = m / n;
  const int per_row = (side - s.markers.first_offset_px) / m;
  const int images = std::min(3, s.phase_sets[0].steps);
  for (int i = 0; i < images; ++i) {
    for (int j = 0; j < n; ++j) {
      for (int k = 0; k < per_row; ++k) {
        MarkerPosition p;
        p.image = s.PhaseImageIndex(0) + i;
        p.period = i * n + j;
        p.u = 3 * period / 4 + j * period + i * period * n - i * period / 3;
        p.across = s.markers.first_offset_px + k * m + j * mn_ratio;
        out.push_back(p);
      }
    }
  }
  return out;
}

std::vector<std::string> PatternScheme::ImageNames() const {
  if (!image_names.empty()) return image_names;
  std::vector<std::string> names;
  for (int i = 0; i < NumImages(); ++i) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%02d.png", i);
    names.emplace_back(buf);
  }
  return names;
}

void PatternScheme::Check() const {
  const char* o = "PatternScheme";
  CheckOption(projector_width > 0, o, "projector_width", projector_width, "must be > 0");
  CheckOption(projector_height > 0, o, "projector_height", projector_height, "must be > 0");
  CheckOption(!phase_sets.empty() || (gray_bits > 0 && gray_period_px > 0), o, "phase_sets",
              phase_sets.size(),
              "need at least one phase-shift set (or pure Gray code: gray_bits > 0 and "
              "gray_period_px > 0)");
  if (phase_sets.empty()) {
    CheckOption(std::isfinite(gray_period_px) && gray_period_px >= 1, o, "gray_period_px",
                gray_period_px, "must be >= 1 projector pixel");
    CheckOption(!gray_complementary, o, "gray_complementary", gray_complementary,
                "needs a phase-shift set to pick the order near stripe edges");
  } else {
    CheckOption(gray_period_px == 0 || gray_period_px == phase_sets[0].period_px, o,
                "gray_period_px", gray_period_px,
                "must be 0 (or the period of phase set 0) when there are phase-shift sets");
  }
  // A pure Gray code bit needs a reference: its inverse or the white and dark frames.
  CheckOption(!phase_sets.empty() || gray_inverted || (white_frame && dark_frame), o,
              "gray_inverted", gray_inverted,
              "pure Gray code needs inverted images or white and dark frames to threshold by");
  CheckOption(!gray_inverted || gray_bits > 0, o, "gray_inverted", gray_inverted,
              "needs Gray code (gray_bits > 0)");
  // The decoder's phase-set loops assume the phase images come first; only pure Gray code
  // (SLStudio's order) puts the reference frames in front.
  CheckOption(!reference_frames_first || phase_sets.empty(), o, "reference_frames_first",
              reference_frames_first, "is supported for pure Gray code only");
  CheckOption(phase_sets.size() <= kMaxPhaseSets, o, "phase_sets", phase_sets.size(),
              StrCat("at most ", kMaxPhaseSets, " sets").c_str());
  for (size_t i = 0; i < phase_sets.size(); ++i) {
    const auto& s = phase_sets[i];
    const std::string f = StrCat("phase_sets[", i, "]");
    CheckOption(std::isfinite(s.period_px) && s.period_px > 2.0, o, (f + ".period_px").c_str(),
                s.period_px, "must be > 2 projector pixels");
    CheckOption(s.steps >= 3 && s.steps <= kMaxSteps, o, (f + ".steps").c_str(), s.steps,
                StrCat("must be in [3, ", kMaxSteps, "]").c_str());
    CheckOption(s.shifts_rad.empty() || static_cast<int>(s.shifts_rad.size()) == s.steps, o,
                (f + ".shifts_rad").c_str(), s.shifts_rad.size(),
                "must be empty or have one shift per step");
    CheckOption(std::isfinite(s.phase_offset_rad), o, (f + ".phase_offset_rad").c_str(),
                s.phase_offset_rad, "must be finite");
    for (size_t k = 0; k < s.flat_steps.size(); ++k) {
      CheckOption(s.flat_steps[k] >= 0 && s.flat_steps[k] < s.steps &&
                      (k == 0 || s.flat_steps[k] > s.flat_steps[k - 1]),
                  o, (f + ".flat_steps").c_str(), s.flat_steps[k],
                  "must be increasing step indices in [0, steps)");
    }
    CheckOption(s.steps - static_cast<int>(s.flat_steps.size()) >= 2, o,
                (f + ".flat_steps").c_str(), s.flat_steps.size(),
                "leave at least two steps with the fringe");
    const double cond = ShiftConditioning(s);
    CheckOption(cond > 1e-3, o, (f + ".shifts_rad").c_str(), cond,
                "shifts do not determine the phase (conditioning of the least-squares system)");
  }
  CheckOption(gray_bits >= 0 && gray_bits <= 16, o, "gray_bits", gray_bits, "must be in [0, 16]");
  CheckOption(intensity_mean > 0 && intensity_mean < 1, o, "intensity_mean", intensity_mean,
              "must be in (0, 1)");
  CheckOption(intensity_amplitude > 0 && intensity_amplitude <= intensity_mean &&
                  intensity_mean + intensity_amplitude <= 1.0 + 1e-12,
              o, "intensity_amplitude", intensity_amplitude,
              "must be in (0, intensity_mean] with mean + amplitude <= 1");
  // Projector gammas lie near 1.8-2.6; beyond 10 the value is a typo or a hostile file.
  CheckOption(gamma_precompensation > 0 && gamma_precompensation <= 10, o, "gamma_precompensation",
              gamma_precompensation, "must be in (0, 10]");
  CheckOption(projector_width <= util::kMaxImageSidePx, o, "projector_width", projector_width,
              StrCat("must be <= ", util::kMaxImageSidePx).c_str());
  CheckOption(projector_height <= util::kMaxImageSidePx, o, "projector_height", projector_height,
              StrCat("must be <= ", util::kMaxImageSidePx).c_str());
  CheckOption(static_cast<long long>(projector_width) * projector_height <= util::kMaxImagePixels,
              o, "projector_width x projector_height",
              static_cast<long long>(projector_width) * projector_height,
              StrCat("must be <= ", util::kMaxImagePixels, " pixels").c_str());
  if (!image_names.empty()) {
    util::CheckRelativeNames(image_names, StrCat(o, ".image_names"), util::ImageExtensions(),
                             "image name");
  }
  CheckOption(image_names.empty() || static_cast<int>(image_names.size()) == NumImages(), o,
              "image_names", image_names.size(),
              StrCat("must be empty or name all ", NumImages(), " images").c_str());
  const double span = Span();
  const Unwrapping method = Method();
  const std::string field = StrCat(o, ".unwrapping");
  const auto require = [&](bool ok, const std::string& what) {
    if (!ok) {
      throw Error(StrCat(field, " = \"", UnwrappingName(method), "\": ", what,
                         unwrapping == Unwrapping::kAuto ? " (or name a method)" : ""));
    }
  };
  if (method != Unwrapping::kGray) {
    require(gray_bits == 0, StrCat("does not use Gray code, but gray_code.bits = ", gray_bits));
  }
  CheckOption(phase_retrieval == PhaseRetrieval::kLeastSquares || method == Unwrapping::kSpatial, o,
              "phase_retrieval", PhaseRetrievalName(phase_retrieval),
              "Fourier methods (ftp, faps) need \"unwrapping\": \"spatial\" (one set of many "
              "periods)");
  CheckOption(!markers.Present() || method == Unwrapping::kSpatial, o, "markers",
              markers.spacing_px, "are for \"unwrapping\": \"spatial\"");
  if (markers.Present()) {
    CheckOption(markers.spacing_px >= 3 && markers.spacing_px <= util::kMaxImageSidePx, o,
                "markers.spacing_px", markers.spacing_px, "must be in [3, 32768]");
    CheckOption(markers.first_offset_px >= 1 && markers.first_offset_px <= util::kMaxImageSidePx, o,
                "markers.first_offset_px", markers.first_offset_px, "must be in [1, 32768]");
    CheckOption(markers.periods >= 3 && markers.periods <= Span(), o, "markers.periods",
                markers.periods, "must be in [3, span] (the layout's groups need 3 periods)");
  }
  switch (method) {
    case Unwrapping::kAuto:
      break;
    case Unwrapping::kGray: {
      require(gray_bits > 0, "needs Gray code (gray_code.bits > 0)");
      const double covered = std::ldexp(1.0, gray_bits) * GrayPeriod();
      CheckOption(covered >= span * (1 - kSpanTolerance), o, "gray_bits", gray_bits,
                  StrCat("2^bits periods of ", GrayPeriod(),
                         " px must cover the projector span of ", span, " px")
                      .c_str());
      break;
    }
    case Unwrapping::kHeterodyne: {
      const std::string why = HeterodyneMisfit();
      if (!why.empty()) {
        // Today's message when the method was not named (manifests written before the field).
        if (unwrapping == Unwrapping::kAuto) {
          CheckOption(false, o, "phase_sets", phase_sets.back().period_px,
                      StrCat(why, " (or add Gray code, or set \"unwrapping\")").c_str());
        }
        require(false, why);
      }
      break;
    }
    case Unwrapping::kHierarchical: {
      require(phase_sets.size() >= 2, "needs two or more phase sets");
      for (size_t i = 0; i + 1 < phase_sets.size(); ++i) {
        require(phase_sets[i + 1].period_px > phase_sets[i].period_px * (1 + 1e-9),
                StrCat("periods must increase from set to set (phase_sets[", i + 1,
                       "].period_px = ", phase_sets[i + 1].period_px, " after ",
                       phase_sets[i].period_px, ")"));
      }
      require(phase_sets.back().period_px >= span * (1 - kSpanTolerance),
              StrCat("the coarsest set (phase_sets[", phase_sets.size() - 1,
                     "].period_px = ", phase_sets.back().period_px,
                     ") must cover the projector span of ", span, " px"));
      break;
    }
    case Unwrapping::kNumberTheoretic:
      MakeNumberTheoreticTable(*this, o);
      break;
    case Unwrapping::kSpatial: {
      require(phase_sets.size() == 1,
              StrCat("unwraps one phase set across the image, the scheme has ", phase_sets.size()));
      // Markers are needed to decode (DecodeSpatial says so); patterns without them, as the
      // tool's default writes them, are a valid scheme.
      require(phase_sets[0].steps >= 3 && phase_sets[0].flat_steps.empty(),
              "needs 3 (or more) fringe images");
      if (markers.Present()) {
        const double p = markers.Period(Span());
        require(p > 2 && std::abs(phase_sets[0].period_px - p) <= 1e-4 * p,
                StrCat("phase_sets[0].period_px = ", phase_sets[0].period_px,
                       " must be the markers' period span / markers.periods = ", p, " px"));
      }
      break;
    }
  }
}

std::string PatternScheme::HeterodyneMisfit() const {
  // Heterodyne chain: beat adjacent sets level by level; periods must grow at every level and
  // the last (coarsest) period must cover the span so that the order is unambiguous.
  std::vector<double> p;
  for (const auto& s : phase_sets) p.push_back(s.period_px);
  if (p.empty()) return "needs phase-shift sets";
  while (p.size() > 1) {
    std::vector<double> next;
    for (size_t i = 0; i + 1 < p.size(); ++i) {
      if (!(p[i + 1] > p[i] * (1 + 1e-9))) {
        return StrCat("periods (and their beat periods) must increase for heterodyne unwrapping (",
                      p[i + 1], " after ", p[i], ")");
      }
      next.push_back(BeatPeriod(p[i], p[i + 1]));
    }
    p = next;
  }
  // Relative tolerance: periods given as span / count (1280/70, 1280/64, 1280/59) have a beat
  // of beats equal to the span up to rounding (1279.9999999999914).
  if (!(p[0] >= Span() * (1 - kSpanTolerance))) {
    return StrCat("the coarsest (beat) period ", p[0], " must cover the projector span of ", Span(),
                  " px");
  }
  return "";
}

Unwrapping PatternScheme::Method() const {
  if (unwrapping != Unwrapping::kAuto) return unwrapping;
  if (gray_bits > 0 || phase_sets.empty()) return Unwrapping::kGray;
  if (phase_sets.size() >= 2 && HeterodyneMisfit().empty()) return Unwrapping::kHeterodyne;
  // A coarsest set covering the span by itself (SLStudio's 2x3: 16 periods + 1 period).
  if (phase_sets.size() >= 2 && phase_sets.back().period_px >= Span() * (1 - kSpanTolerance)) {
    bool increasing = true;
    for (size_t i = 0; i + 1 < phase_sets.size(); ++i) {
      increasing = increasing && phase_sets[i + 1].period_px > phase_sets[i].period_px;
    }
    if (increasing) return Unwrapping::kHierarchical;
  }
  return Unwrapping::kHeterodyne;
}

const char* UnwrappingName(Unwrapping u) {
  switch (u) {
    case Unwrapping::kAuto:
      return "auto";
    case Unwrapping::kHeterodyne:
      return "heterodyne";
    case Unwrapping::kGray:
      return "gray";
    case Unwrapping::kHierarchical:
      return "hierarchical";
    case Unwrapping::kNumberTheoretic:
      return "number-theoretic";
    case Unwrapping::kSpatial:
      return "spatial";
  }
  return "?";
}

int NumberTheoreticTable::Lookup(const int* m) const {
  size_t index = 0;
  for (size_t j = 0; j < key_min.size(); ++j) {
    const int d = m[j] - key_min[j];
    if (d < 0 || d >= key_size[j]) return -1;
    index = index * static_cast<size_t>(key_size[j]) + static_cast<size_t>(d);
  }
  return k0[index];
}

NumberTheoreticTable MakeNumberTheoreticTable(const PatternScheme& scheme,
                                              const std::string& context) {
  const std::string field = StrCat(context, ".unwrapping = \"number-theoretic\"");
  const auto& sets = scheme.phase_sets;
  if (sets.size() < 2 || sets.size() > 3) {
    throw Error(StrCat(field, ": needs two or three phase sets, the scheme has ", sets.size()));
  }
  // The common length: the smallest whole number of periods of the coarsest set holding a whole
  // number of every other period (relative tolerance for periods written as L / count).
  constexpr int kMaxCount = 4096;
  const double coarse = std::max_element(sets.begin(), sets.end(), [](auto& a, auto& b) {
                          return a.period_px < b.period_px;
                        })->period_px;
  NumberTheoreticTable t;
  for (int n = 1; n <= kMaxCount && t.counts.empty(); ++n) {
    const double length = n * coarse;
    std::vector<int> counts;
    for (const auto& set : sets) {
      const double f = length / set.period_px;
      if (std::abs(f - std::round(f)) > 1e-6 * f) break;
      counts.push_back(static_cast<int>(std::lround(f)));
    }
    if (counts.size() == sets.size()) {
      t.length_px = length;
      t.counts = counts;
    }
  }
  if (t.counts.empty()) {
    throw Error(StrCat(field, ": the periods have no common length within ", kMaxCount,
                       " periods of the coarsest set (fringe counts must be integers over it)"));
  }
  std::string counts_text;
  for (const int f : t.counts) counts_text += StrCat(counts_text.empty() ? "" : ", ", f);
  if (t.length_px < scheme.Span() * (1 - kSpanTolerance)) {
    throw Error(StrCat(field, ": the common length ", t.length_px, " px (fringe counts ",
                       counts_text, ") is shorter than the projector span of ", scheme.Span(),
                       " px: the counts share a factor or are too small"));
  }
  // Segments of [0, 1) (fractions of L) between the sets' period boundaries j / f_s.
  std::vector<double> cuts = {0.0, 1.0};
  for (const int f : t.counts) {
    for (int j = 1; j < f; ++j) cuts.push_back(static_cast<double>(j) / f);
  }
  std::sort(cuts.begin(), cuts.end());
  const size_t n = sets.size();
  std::vector<std::vector<int>> keys;
  std::vector<int> orders;
  for (size_t i = 0; i + 1 < cuts.size(); ++i) {
    if (cuts[i + 1] - cuts[i] < 1e-12) continue;
    const double x = 0.5 * (cuts[i] + cuts[i + 1]);
    std::vector<int> k(n);
    for (size_t s = 0; s < n; ++s) k[s] = static_cast<int>(std::floor(x * t.counts[s]));
    std::vector<int> key(n - 1);
    for (size_t j = 1; j < n; ++j) key[j - 1] = t.counts[j] * k[0] - t.counts[0] * k[j];
    keys.push_back(key);
    orders.push_back(k[0]);
  }
  t.key_min.assign(n - 1, std::numeric_limits<int>::max());
  std::vector<int> key_max(n - 1, std::numeric_limits<int>::min());
  for (const auto& key : keys) {
    for (size_t j = 0; j + 1 < n; ++j) {
      t.key_min[j] = std::min(t.key_min[j], key[j]);
      key_max[j] = std::max(key_max[j], key[j]);
    }
  }
  size_t total = 1;
  for (size_t j = 0; j + 1 < n; ++j) {
    t.key_size.push_back(key_max[j] - t.key_min[j] + 1);
    total *= static_cast<size_t>(t.key_size.back());
  }
  t.k0.assign(total, -1);
  for (size_t i = 0; i < keys.size(); ++i) {
    size_t index = 0;
    for (size_t j = 0; j + 1 < n; ++j) {
      index = index * static_cast<size_t>(t.key_size[j]) +
              static_cast<size_t>(keys[i][j] - t.key_min[j]);
    }
    if (t.k0[index] >= 0 && t.k0[index] != orders[i]) {
      throw Error(StrCat(field, ": fringe counts ", counts_text,
                         " give two positions the same key (not co-prime): the orders would be "
                         "ambiguous"));
    }
    t.k0[index] = orders[i];
  }
  return t;
}

std::vector<std::string> SchemePresetNames() {
  return {"heterodyne-4x3", "thesis-4+3+3", "heterodyne-3x3", "gray+4", "slsdk-phasegray"};
}

PatternScheme MakeScheme(const std::string& preset, int projector_width, int projector_height) {
  PatternScheme s;
  s.name = preset;
  s.projector_width = projector_width;
  s.projector_height = projector_height;
  CheckOption(projector_width > 0, "MakeScheme", "projector_width", projector_width, "must be > 0");
  CheckOption(projector_height > 0, "MakeScheme", "projector_height", projector_height,
              "must be > 0");
  const double span = s.Span();
  auto heterodyne = [&](int n0, int n1, int n2) {
    // Fringe counts 70, 64, 59 over L: beats of L/6 and L/5, beat of beats L = 1.25 span. The
    // margin of 0.125 span on each side keeps pixels at the projector's edges away from the
    // wrap of the beat of beats (its position noise is ~L/(2 pi) sqrt(6) sigma_phi).
    const double l = 1.25 * span;
    for (int i = 0; i < 3; ++i) {
      PhaseShiftSet set;
      set.period_px = l / (i == 0 ? 70 : i == 1 ? 64 : 59);
      set.steps = i == 0 ? n0 : i == 1 ? n1 : n2;
      s.phase_sets.push_back(set);
    }
  };
  if (preset == "heterodyne-4x3") {
    heterodyne(4, 4, 4);
  } else if (preset == "thesis-4+3+3") {
    heterodyne(4, 3, 3);
  } else if (preset == "heterodyne-3x3") {
    heterodyne(3, 3, 3);
  } else if (preset == "gray+4") {
    int bits = 1;
    while (span / std::ldexp(1.0, bits) > 32.0) ++bits;
    PhaseShiftSet set;
    set.period_px = span / std::ldexp(1.0, bits);
    set.steps = 4;
    s.phase_sets.push_back(set);
    s.gray_bits = bits;
    s.gray_complementary = true;
  } else if (preset == "slsdk-phasegray") {
    // ../shared/data/README.md: wrapped phase atan2(I3 - I1, I0 - I2) is -pi at the start of
    // each period, so I_k = A + B cos(phi + k pi / 2) with phi = Phi - pi; 32 periods of 60 px
    // on the 1920-wide DLP4710.
    s.projector_width = 1920;
    s.projector_height = 1080;
    PhaseShiftSet set;
    set.period_px = 60.0;
    set.steps = 4;
    set.phase_offset_rad = -M_PI;
    s.phase_sets.push_back(set);
    s.gray_bits = 5;
    s.gray_complementary = true;
    for (int i = 0; i < 10; ++i) s.image_names.push_back(StrCat(i, ".png"));
  } else {
    std::string names;
    for (const auto& n : SchemePresetNames()) names += (names.empty() ? "" : ", ") + n;
    throw Error(StrCat("unknown pattern scheme preset '", preset, "' (presets: ", names,
                       "; or give a manifest JSON file)"));
  }
  s.Check();
  return s;
}

json SchemeToJson(const PatternScheme& scheme) {
  json j;
  j["format"] = "fringe-patterns";
  j["version"] = 1;
  j["name"] = scheme.name;
  j["projector"] = {{"width", scheme.projector_width}, {"height", scheme.projector_height}};
  j["direction"] = DirectionName(scheme.direction);
  j["intensity"] = {{"mean", scheme.intensity_mean}, {"amplitude", scheme.intensity_amplitude}};
  j["gamma_precompensation"] = scheme.gamma_precompensation;
  json sets = json::array();
  for (const auto& s : scheme.phase_sets) {
    json js = {{"period_px", s.period_px},
               {"steps", s.steps},
               {"shifts_rad", s.Shifts()},
               {"phase_offset_rad", s.phase_offset_rad}};
    if (!s.flat_steps.empty()) js["flat_steps"] = s.flat_steps;
    sets.push_back(js);
  }
  j["phase_sets"] = sets;
  j["gray_code"] = {{"bits", scheme.gray_bits}, {"complementary", scheme.gray_complementary}};
  // Keys of other tools' conventions only when they differ from fringe's own, so that fringe's
  // manifests stay as they were.
  if (scheme.gray_inverted) j["gray_code"]["inverted"] = true;
  if (scheme.gray_period_px > 0) j["gray_code"]["period_px"] = scheme.gray_period_px;
  if (scheme.unwrapping != Unwrapping::kAuto) j["unwrapping"] = UnwrappingName(scheme.unwrapping);
  j["white_frame"] = scheme.white_frame;
  j["dark_frame"] = scheme.dark_frame;
  if (scheme.reference_frames_first) j["reference_frames"] = "first";
  if (scheme.quantization != Quantization::kRound) {
    j["quantization"] = QuantizationName(scheme.quantization);
  }
  if (scheme.arithmetic != Arithmetic::kDouble) j["arithmetic"] = ArithmeticName(scheme.arithmetic);
  if (scheme.phase_retrieval != PhaseRetrieval::kLeastSquares) {
    j["phase_retrieval"] = PhaseRetrievalName(scheme.phase_retrieval);
  }
  if (scheme.markers.Present()) {
    j["markers"] = {{"layout", "opencv"},
                    {"spacing_px", scheme.markers.spacing_px},
                    {"periods", scheme.markers.periods},
                    {"first_offset_px", scheme.markers.first_offset_px}};
  }
  j["images"] = scheme.ImageNames();
  return j;
}

PatternScheme SchemeFromJson(const json& j, const std::string& context) {
  io::RequireObject(j, context);
  return io::WithJsonContext(context, [&] {
    PatternScheme s;
    // A manifest of another tool (or another kind of fringe file) is named as such, with the
    // way out, instead of a complaint about its first unknown key.
    const auto foreign = [&](const std::string& why) {
      return Error(StrCat(context, ": not a fringe pattern manifest (", why,
                          "); give the scheme with --scheme (a preset such as gray+N with "
                          "--width/--height/--period, or a fringe manifest, docs/formats.md)"));
    };
    if (j.contains("format") && j["format"] != "fringe-patterns") {
      throw foreign(
          StrCat("\"format\" is ", io::Brief(j["format"]), ", expected \"fringe-patterns\""));
    }
    if (!j.contains("format") && !j.contains("phase_sets")) {
      throw foreign("no \"format\": \"fringe-patterns\" and no \"phase_sets\"");
    }
    io::CheckKnownKeys(j,
                       {"format", "version", "name", "projector", "direction", "intensity",
                        "gamma_precompensation", "phase_sets", "gray_code", "unwrapping",
                        "white_frame", "dark_frame", "reference_frames", "quantization",
                        "arithmetic", "phase_retrieval", "markers", "images"},
                       context);
    io::OptionalInteger(j, "version", 1, 1, 1, context);
    s.name = io::OptionalString(j, "name", s.name, context);
    if (!j.contains("projector")) throw Error(StrCat(context, ": missing \"projector\""));
    const std::string pc = context + ".projector";
    io::CheckKnownKeys(j["projector"], {"width", "height"}, pc);
    s.projector_width =
        static_cast<int>(io::GetInteger(j["projector"], "width", 1, util::kMaxImageSidePx, pc));
    s.projector_height =
        static_cast<int>(io::GetInteger(j["projector"], "height", 1, util::kMaxImageSidePx, pc));
    const std::string d = io::OptionalString(j, "direction", "vertical", context);
    if (d == "vertical") {
      s.direction = FringeDirection::kVertical;
    } else if (d == "horizontal") {
      s.direction = FringeDirection::kHorizontal;
    } else {
      throw Error(StrCat(context, ".direction: ", io::Brief(j["direction"]),
                         ": expected \"vertical\" or \"horizontal\""));
    }
    if (j.contains("intensity")) {
      const std::string ic = context + ".intensity";
      io::CheckKnownKeys(j["intensity"], {"mean", "amplitude"}, ic);
      s.intensity_mean = io::OptionalNumber(j["intensity"], "mean", s.intensity_mean, ic);
      s.intensity_amplitude =
          io::OptionalNumber(j["intensity"], "amplitude", s.intensity_amplitude, ic);
    }
    s.gamma_precompensation = io::OptionalNumber(j, "gamma_precompensation", 1.0, context);
    // Pure Gray code (gray_code.period_px) has no phase set.
    const bool pure_gray = j.contains("gray_code") && j["gray_code"].is_object() &&
                           j["gray_code"].contains("period_px");
    if (!j.contains("phase_sets") || !j["phase_sets"].is_array() ||
        (j["phase_sets"].empty() && !pure_gray)) {
      throw Error(StrCat(context, ": missing array \"phase_sets\""));
    }
    if (j["phase_sets"].size() > kMaxPhaseSets) {
      throw Error(StrCat(context, ".phase_sets: ", j["phase_sets"].size(), " sets, more than the ",
                         kMaxPhaseSets, " supported"));
    }
    for (size_t i = 0; i < j["phase_sets"].size(); ++i) {
      const json& js = j["phase_sets"][i];
      const std::string sc = StrCat(context, ".phase_sets[", i, "]");
      io::CheckKnownKeys(js, {"period_px", "steps", "shifts_rad", "phase_offset_rad", "flat_steps"},
                         sc);
      PhaseShiftSet set;
      set.period_px = io::GetNumber(js, "period_px", sc);
      set.steps = static_cast<int>(io::GetInteger(js, "steps", 3, kMaxSteps, sc));
      if (js.contains("shifts_rad")) {
        const json& sh = js["shifts_rad"];
        if (!sh.is_array() || static_cast<int>(sh.size()) != set.steps) {
          throw Error(StrCat(sc, ".shifts_rad: expected ", set.steps, " numbers (one per step)"));
        }
        for (size_t k = 0; k < sh.size(); ++k) {
          set.shifts_rad.push_back(io::AsNumber(sh[k], StrCat(sc, ".shifts_rad[", k, "]")));
        }
      }
      set.phase_offset_rad = io::OptionalNumber(js, "phase_offset_rad", 0.0, sc);
      if (js.contains("flat_steps")) {
        const json& fl = js["flat_steps"];
        if (!fl.is_array() || static_cast<int>(fl.size()) > set.steps) {
          throw Error(
              StrCat(sc, ".flat_steps: expected an array of at most ", set.steps, " step indices"));
        }
        for (size_t k = 0; k < fl.size(); ++k) {
          set.flat_steps.push_back(static_cast<int>(
              io::AsInteger(fl[k], 0, set.steps - 1, StrCat(sc, ".flat_steps[", k, "]"))));
        }
      }
      s.phase_sets.push_back(set);
    }
    if (j.contains("gray_code")) {
      const std::string gc = context + ".gray_code";
      io::CheckKnownKeys(j["gray_code"], {"bits", "complementary", "inverted", "period_px"}, gc);
      s.gray_bits = static_cast<int>(io::OptionalInteger(j["gray_code"], "bits", 0, 0, 16, gc));
      s.gray_complementary = io::OptionalBool(j["gray_code"], "complementary", false, gc);
      s.gray_inverted = io::OptionalBool(j["gray_code"], "inverted", false, gc);
      s.gray_period_px = io::OptionalNumber(j["gray_code"], "period_px", 0.0, gc);
    }
    if (j.contains("unwrapping")) {
      const std::string u = io::OptionalString(j, "unwrapping", "auto", context);
      bool known = false;
      for (const Unwrapping m :
           {Unwrapping::kAuto, Unwrapping::kHeterodyne, Unwrapping::kGray,
            Unwrapping::kHierarchical, Unwrapping::kNumberTheoretic, Unwrapping::kSpatial}) {
        if (u == UnwrappingName(m)) {
          s.unwrapping = m;
          known = true;
        }
      }
      if (!known) {
        throw Error(StrCat(context, ".unwrapping: ", io::Brief(j["unwrapping"]),
                           ": expected \"heterodyne\", \"gray\", \"hierarchical\", "
                           "\"number-theoretic\", \"spatial\" or \"auto\""));
      }
    }
    s.white_frame = io::OptionalBool(j, "white_frame", false, context);
    s.dark_frame = io::OptionalBool(j, "dark_frame", false, context);
    // Named choices: the value must be one of the listed names.
    const auto choice = [&](const char* key, const std::vector<std::string>& names) {
      const std::string v = io::OptionalString(j, key, names[0], context);
      for (size_t k = 0; k < names.size(); ++k) {
        if (v == names[k]) return static_cast<int>(k);
      }
      std::string list;
      for (const auto& n : names) list += StrCat(list.empty() ? "" : " or ", "\"", n, "\"");
      throw Error(StrCat(context, ".", key, ": ", io::Brief(j[key]), ": expected ", list));
    };
    s.reference_frames_first = choice("reference_frames", {"last", "first"}) == 1;
    s.quantization = static_cast<Quantization>(choice(
        "quantization",
        {QuantizationName(Quantization::kRound), QuantizationName(Quantization::kRoundHalfEven),
         QuantizationName(Quantization::kFloor)}));
    s.arithmetic = static_cast<Arithmetic>(choice(
        "arithmetic", {ArithmeticName(Arithmetic::kDouble), ArithmeticName(Arithmetic::kFloat32),
                       ArithmeticName(Arithmetic::kFloat32Wrapped)}));
    s.phase_retrieval = static_cast<PhaseRetrieval>(choice(
        "phase_retrieval",
        {PhaseRetrievalName(PhaseRetrieval::kLeastSquares),
         PhaseRetrievalName(PhaseRetrieval::kFtp), PhaseRetrievalName(PhaseRetrieval::kFaps)}));
    if (j.contains("markers")) {
      const std::string mc = context + ".markers";
      io::RequireObject(j["markers"], mc);
      io::CheckKnownKeys(j["markers"], {"layout", "spacing_px", "periods", "first_offset_px"}, mc);
      const std::string layout = io::OptionalString(j["markers"], "layout", "opencv", mc);
      if (layout != "opencv") {
        throw Error(
            StrCat(mc, ".layout: ", io::Brief(j["markers"]["layout"]), ": expected \"opencv\""));
      }
      s.markers.spacing_px = static_cast<int>(
          io::GetInteger(j["markers"], "spacing_px", 3, util::kMaxImageSidePx, mc));
      s.markers.periods =
          static_cast<int>(io::GetInteger(j["markers"], "periods", 3, util::kMaxImageSidePx, mc));
      s.markers.first_offset_px = static_cast<int>(
          io::OptionalInteger(j["markers"], "first_offset_px", 10, 1, util::kMaxImageSidePx, mc));
    }
    if (j.contains("images")) {
      const json& names = j["images"];
      if (!names.is_array()) throw Error(StrCat(context, ".images: expected an array of names"));
      if (static_cast<int>(names.size()) != s.NumImages()) {
        throw Error(StrCat(context, ".images: ", names.size(), " names for the ", s.NumImages(),
                           " images the scheme has"));
      }
      for (size_t k = 0; k < names.size(); ++k) {
        s.image_names.push_back(io::AsString(names[k], StrCat(context, ".images[", k, "]")));
      }
      util::CheckRelativeNames(s.image_names, context + ".images", util::ImageExtensions(),
                               "image name");
    }
    s.Check();
    return s;
  });
}

PatternScheme ReadScheme(const std::filesystem::path& path) {
  return SchemeFromJson(io::ReadJson(path), path.string());
}

void WriteScheme(const std::filesystem::path& path, const PatternScheme& scheme) {
  scheme.Check();
  io::WriteJson(path, SchemeToJson(scheme));
}

PatternScheme SchemeFromNameOrFile(const std::string& name_or_path, int projector_width,
                                   int projector_height) {
  const auto presets = SchemePresetNames();
  if (std::find(presets.begin(), presets.end(), name_or_path) != presets.end()) {
    return MakeScheme(name_or_path, projector_width, projector_height);
  }
  if (std::filesystem::exists(name_or_path)) return ReadScheme(name_or_path);
  // A path-like argument that does not exist is a missing file, not an unknown preset.
  const std::filesystem::path p(name_or_path);
  if (p.has_parent_path() || p.has_extension()) {
    throw Error(StrCat(name_or_path, ": scheme manifest: no such file"));
  }
  return MakeScheme(name_or_path, projector_width, projector_height);  // throws, listing presets
}

double PatternIntensity(const PatternScheme& s, int index, double u) {
  assert(index >= 0 && index < s.NumImages());
  const double v = u + 0.5;  // from the projector's leading edge
  int i = index;
  if (s.reference_frames_first) {
    if (i < s.NumReferenceImages()) return i == 0 && s.white_frame ? 1.0 : 0.0;
    i -= s.NumReferenceImages();
  }
  for (const auto& set : s.phase_sets) {
    if (i < set.steps) {
      if (set.IsFlat(i)) return s.intensity_mean;
      const double shift = set.shifts_rad.empty() ? kTwoPi * i / set.steps : set.shifts_rad[i];
      return s.intensity_mean + s.intensity_amplitude * std::cos(kTwoPi * v / set.period_px +
                                                                 set.phase_offset_rad + shift);
    }
    i -= set.steps;
  }
  if (i < s.NumGrayImages()) {
    const bool inverse = s.gray_inverted && (i % 2 == 1);
    const int bit = s.gray_inverted ? i / 2 : i;
    // Bit `bit` (0 = most significant) of the (bits+1)-bit Gray code of the half-period index;
    // its first `bits` bits equal the bits-bit Gray code of the period index.
    const long half = static_cast<long>(std::floor(2.0 * v / s.GrayPeriod()));
    const unsigned code = Gray(static_cast<unsigned>(std::max(half, 0L)));
    const bool bright = ((code >> (s.gray_bits - bit)) & 1u) != 0;
    return bright != inverse ? 1.0 : 0.0;
  }
  i -= s.NumGrayImages();
  if (s.white_frame && i == 0) return 1.0;
  return 0.0;  // dark frame
}

namespace {

// Image `index` is a phase-shift image: its set and step (false otherwise).
bool PhaseStep(const PatternScheme& s, int index, int* set, int* step) {
  int i = index - (s.reference_frames_first ? s.NumReferenceImages() : 0);
  if (i < 0) return false;
  for (size_t k = 0; k < s.phase_sets.size(); ++k) {
    if (i < s.phase_sets[k].steps) {
      *set = static_cast<int>(k);
      *step = i;
      return true;
    }
    i -= s.phase_sets[k].steps;
  }
  return false;
}

// Arithmetic::kFloat32 (pattern_scheme.h): the profile of one phase-shift image at pixel index u,
// every operation rounded to single precision as SLStudio's pstools::computePhaseVector does.
float Float32Profile(const PatternScheme& s, int set, int step, int u) {
  const PhaseShiftSet& ps = s.phase_sets[set];
  const double shift = ps.Shifts()[step];
  const float two_pi = static_cast<float>(kTwoPi);
  const float period = static_cast<float>(ps.period_px);
  const float delta = static_cast<float>(ps.phase_offset_rad + shift + M_PI / ps.period_px);
  const float arg = two_pi * static_cast<float>(u) / period + delta;
  return static_cast<float>(s.intensity_mean) +
         static_cast<float>(s.intensity_amplitude) * std::cos(arg);
}

// Arithmetic::kFloat32Wrapped (pattern_scheme.h): SLMaster's ThreeFrequencyHeterodynePattern::
// generate, the phase wrapped to one period in single precision before a single-precision
// cosine (SLMaster builds with MSVC, whose cos(float) is the float overload); the sum in double.
// The value on the byte scale, 255 mean + 255 amplitude cos (127.5 + 127.5 cos for SLMaster).
double Float32WrappedProfile(const PatternScheme& s, int set, int step, int u) {
  const PhaseShiftSet& ps = s.phase_sets[set];
  const float period = static_cast<float>(ps.period_px);
  const float t = static_cast<float>(u) / period;
  const float d = t - std::floor(t);
  const float wrapped = static_cast<float>((2.0f * d - 1.0f) * M_PI);
  // The phase at the period start beyond -pi: 0 for SLMaster's own offset -pi - pi / P (kept
  // exactly 0 when the offset was written as that sum).
  double start = ps.phase_offset_rad + M_PI + M_PI / ps.period_px;
  if (std::abs(start) < 1e-9) start = 0.0;
  const float delta = static_cast<float>(ps.Shifts()[step] + start);
  const float arg = wrapped + delta;
  return 255.0 * s.intensity_mean +
         255.0 * s.intensity_amplitude * static_cast<double>(std::cos(arg));
}

}  // namespace

std::vector<cv::Mat> GeneratePatterns(const PatternScheme& scheme, double precompensate_gamma) {
  scheme.Check();
  CheckOption(precompensate_gamma > 0 && std::isfinite(precompensate_gamma), "GeneratePatterns",
              "precompensate_gamma", precompensate_gamma, "must be > 0");
  const int w = scheme.projector_width, h = scheme.projector_height;
  const bool vertical = scheme.direction == FringeDirection::kVertical;
  const int span = scheme.Span();
  std::vector<cv::Mat> out;
  std::vector<uint8_t> profile(span);
  for (int i = 0; i < scheme.NumImages(); ++i) {
    int set = 0, step = 0;
    const bool phase = PhaseStep(scheme, i, &set, &step);
    const bool flat = phase && scheme.phase_sets[set].IsFlat(step);
    const Arithmetic arithmetic = phase && !flat ? scheme.arithmetic : Arithmetic::kDouble;
    for (int u = 0; u < span; ++u) {
      if (arithmetic == Arithmetic::kFloat32Wrapped) {
        // Straight from the byte scale as the tool computes it (no round trip through [0, 1],
        // which moves values at the crests across an integer).
        const double x = Float32WrappedProfile(scheme, set, step, u);
        profile[u] = precompensate_gamma == 1.0 ? QuantizeValue(scheme.quantization, x)
                                                : scheme.Quantize(x / 255.0, precompensate_gamma);
        continue;
      }
      const double lin = arithmetic == Arithmetic::kFloat32
                             ? static_cast<double>(Float32Profile(scheme, set, step, u))
                             : PatternIntensity(scheme, i, u);
      if (flat) {
        // A constant frame (the tools' setTo): the nearest byte, ties to even.
        const double x = 255.0 * std::pow(std::clamp(lin, 0.0, 1.0), 1.0 / precompensate_gamma);
        profile[u] = static_cast<uint8_t>(std::nearbyint(x));
      } else {
        profile[u] = scheme.Quantize(lin, precompensate_gamma);
      }
    }
    cv::Mat img(h, w, CV_8UC1);
    for (int r = 0; r < h; ++r) {
      uint8_t* row = img.ptr<uint8_t>(r);
      if (vertical) {
        std::copy(profile.begin(), profile.end(), row);
      } else {
        std::fill(row, row + w, profile[r]);
      }
    }
    out.push_back(img);
  }
  // Markers (PatternMarkers): five-pixel pluses of full brightness on the fringe images.
  for (const MarkerPosition& m : MarkerPositions(scheme)) {
    cv::Mat& img = out[m.image];
    for (const auto& [du, da] : {std::pair{0, 0}, {-1, 0}, {1, 0}, {0, -1}, {0, 1}}) {
      const int u = m.u + du, a = m.across + da;
      if (vertical) {
        img.at<uint8_t>(a, u) = 255;
      } else {
        img.at<uint8_t>(u, a) = 255;
      }
    }
  }
  return out;
}

void WritePatternFolder(const std::filesystem::path& dir, const PatternScheme& scheme_in,
                        double precompensate_gamma) {
  PatternScheme scheme = scheme_in;
  scheme.gamma_precompensation = precompensate_gamma;
  scheme.image_names = scheme.ImageNames();
  const auto images = GeneratePatterns(scheme, precompensate_gamma);
  util::WriteFolderAtomically(dir, [&](const std::filesystem::path& tmp) {
    for (size_t i = 0; i < images.size(); ++i) {
      const auto path = tmp / scheme.image_names[i];
      std::filesystem::create_directories(path.parent_path());
      io::WriteImage(path, images[i]);
    }
    io::WriteJson(tmp / "manifest.json", SchemeToJson(scheme));
  });
}

}  // namespace fringe::phase
