#include "fringe/phase/scheme_presets.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::phase {
namespace {

using util::CheckOption;
using util::StrCat;

// "gray+N" -> N (0 when the name is not of that family).
int GrayFamilySteps(const std::string& preset) {
  if (preset.rfind("gray+", 0) != 0 || preset.size() == 5 || preset.size() > 7) return 0;
  int n = 0;
  for (size_t i = 5; i < preset.size(); ++i) {
    if (!std::isdigit(static_cast<unsigned char>(preset[i]))) return 0;
    n = 10 * n + (preset[i] - '0');
  }
  return n;
}

bool IsHeterodynePreset(const std::string& preset) {
  return preset == "heterodyne-4x3" || preset == "thesis-4+3+3" || preset == "heterodyne-3x3";
}

// ceil(log2(n)) for n >= 1, as the tools compute their bit counts.
int CeilLog2(int n) {
  int bits = 0;
  while ((1L << bits) < n) ++bits;
  return bits;
}

// A tool's pattern: the scheme and, per image of the scheme's stack, the tool's own frame
// number (its position in the tool's sequence, which its file names count).
struct ToolScheme {
  PatternScheme scheme;
  std::vector<int> frames;
  std::string names;  // printf pattern of the tool's file names over `frames`
};

// SLStudio (github.com/jakobwilm/slstudio, src/codec/, revision 13f41924; docs/formats.md):
// pstools::computePhaseVector shows 0.5 (1 + cos(2 pi u / pitch - phase_k)) truncated to a
// byte, evaluated in single precision, with phase_k = float(2 pi_f / N * k) (pi_f = float(pi)).
// In fringe's convention (v = u + 0.5) that is the offset -pi / P and the shifts -phase_k.
PhaseShiftSet SlstudioSet(double period, int steps) {
  PhaseShiftSet set;
  set.period_px = period;
  set.steps = steps;
  set.phase_offset_rad = -M_PI / period;
  const float pi_f = static_cast<float>(M_PI);
  for (int k = 0; k < steps; ++k) {
    set.shifts_rad.push_back(-static_cast<double>(static_cast<float>(2.0 * pi_f / steps * k)));
  }
  return set;
}

// Codecs that SLStudio only has for projector columns (their encoders ignore CodecDir).
bool ColumnsOnly(const std::string& preset) {
  return preset == "slstudio-phaseshift2p1" || preset == "slstudio-phaseshift3fastwrap";
}

// The tools' presets (docs/formats.md, "Other tools' codecs"). `span` and the other sizes are
// the projector's; every preset follows the tool's source revision named there.
ToolScheme MakeToolScheme(const std::string& preset, int width, int height, bool horizontal,
                          double count, int steps, int markers) {
  ToolScheme t;
  PatternScheme& s = t.scheme;
  s.name = preset;
  s.projector_width = width;
  s.projector_height = height;
  s.direction = horizontal ? FringeDirection::kHorizontal : FringeDirection::kVertical;
  const int span = s.Span();
  if (preset.rfind("slstudio-", 0) == 0) {
    t.names = "frameSeq_%d.bmp";  // SLScanWorker writes the sequence as frameSeq_<i>.bmp
    s.quantization = Quantization::kFloor;
    s.arithmetic = Arithmetic::kFloat32;
    if (horizontal && ColumnsOnly(preset)) {
      throw Error(StrCat("scheme ", preset,
                         ": SLStudio's codec codes projector columns only (its encoder ignores "
                         "the direction); --horizontal does not apply"));
    }
    if (preset == "slstudio-phaseshift2x3") {
      // 3 steps at 16 periods over the span, then 3 steps at 1 period (the phase cue).
      s.phase_sets = {SlstudioSet(span / 16.0, 3), SlstudioSet(span, 3)};
      s.unwrapping = Unwrapping::kHierarchical;
    } else if (preset == "slstudio-phaseshift4" || preset == "slstudio-phaseshift3") {
      // One period over the span: absolute on its own. PhaseShift3 rounds (convertTo) and adds
      // fresh Gaussian noise to every pattern (sigma 0.05 of full scale), which no preset can
      // reproduce: fringe shows its noise-free patterns.
      const int n = preset == "slstudio-phaseshift4" ? 4 : 3;
      s.phase_sets = {SlstudioSet(span, n)};
      if (n == 3) s.quantization = Quantization::kRoundHalfEven;
    } else if (preset == "slstudio-phaseshift3fastwrap") {
      // CodecPhaseShift3FastWrap: PhaseShift4's profile with 3 steps, truncated, no dither (the
      // tool decodes it by Zhang's intensity ratio; fringe by least squares).
      s.phase_sets = {SlstudioSet(span, 3)};
    } else if (preset == "slstudio-phaseshift2p1") {
      // CodecPhaseShift2p1: computePhaseVector at phase 0 and pi/2 over one period, then a flat
      // frame setTo(0.5 * 255) = 128 (Zhang & Yau's 2 + 1 algorithm: the flat image is the
      // background).
      PhaseShiftSet set = SlstudioSet(span, 3);
      const float pi_f = static_cast<float>(M_PI);
      set.shifts_rad = {0.0, -static_cast<double>(static_cast<float>(pi_f / 2.0)), 0.0};
      set.flat_steps = {2};
      s.phase_sets = {set};
    } else if (preset == "slstudio-phaseshiftnstep") {
      // CodecPhaseShiftNStep: 9 steps at 8 periods over the span, then a 3-step cue of one
      // period; unwrapped with the cue (hierarchical).
      s.phase_sets = {SlstudioSet(span / 8.0, 9), SlstudioSet(span, 3)};
      s.unwrapping = Unwrapping::kHierarchical;
    } else if (preset == "slstudio-graycode") {
      // White, black, then the Gray code of the column (row) index, most significant bit first:
      // ceil(log2(span)) bits of which only the first 10 (6 for rows) are shown, so the code
      // counts stripes of 2^(bits - shown) pixels.
      const int shown = horizontal ? 6 : 10;
      const int bits = CeilLog2(span);
      if (bits < shown) {
        throw Error(StrCat("scheme ", preset, ": SLStudio shows ", shown,
                           " Gray bits, which needs ", horizontal ? "a height" : "a width",
                           " above ", 1 << (shown - 1), " px (got ", span, ")"));
      }
      s.gray_bits = shown;
      s.gray_period_px = std::ldexp(1.0, bits - shown);
      s.white_frame = s.dark_frame = true;
      s.reference_frames_first = true;
    } else {
      throw Error(StrCat("unknown SLStudio codec '", preset, "'"));
    }
    for (int i = 0; i < s.NumImages(); ++i) t.frames.push_back(i);
  } else if (preset == "opencv-graycode") {
    // structured_light::GrayCodePattern: for every bit (most significant first) the image and
    // its inverse, the column images then the row images; the capture sample appends white and
    // black (getImagesForShadowMasks) and names frame i pattern_cam1_im<i+1>.png.
    const int cols = CeilLog2(width), rows = CeilLog2(height);
    s.gray_bits = horizontal ? rows : cols;
    s.gray_period_px = 1;
    s.gray_inverted = true;
    s.white_frame = s.dark_frame = true;
    const int first = horizontal ? 2 * cols : 0;
    for (int i = 0; i < 2 * s.gray_bits; ++i) t.frames.push_back(first + i + 1);
    t.frames.push_back(2 * (cols + rows) + 1);
    t.frames.push_back(2 * (cols + rows) + 2);
    t.names = "pattern_cam1_im%d.png";
  } else if (preset == "opencv-psp" || preset == "opencv-ftp" || preset == "opencv-faps") {
    // structured_light::SinusoidalPattern (PSP, FTP and FAPS show the same three images):
    // saturate_cast<uchar>(127.5 + 127.5 sin(2 pi f u + i shift)) with period = span /
    // nbrOfPeriods in integer pixels, f = float(1 / period) and shift = float(2 pi / 3); with
    // setMarkers, crosses every nbrOfPixelsBetweenMarkers px (PatternMarkers). One period over
    // the span (opencv-psp's default) is absolute on its own; more periods are unwrapped across
    // the image and fixed by the markers (spatial_decode.h).
    const bool fourier = preset != "opencv-psp";
    const int periods = count > 0 ? static_cast<int>(count) : fourier ? 20 : 1;
    if (count != std::floor(count) || periods > span / 3) {
      throw Error(StrCat("scheme ", preset,
                         ": --counts (nbrOfPeriods) must be a whole number "
                         "of periods of at least 3 px over the span of ",
                         span, " px (got ", count, ")"));
    }
    if (fourier && periods < 3) {
      throw Error(StrCat("scheme ", preset,
                         ": Fourier analysis needs a carrier: at least 3 "
                         "periods over the span (--counts, OpenCV's default 20)"));
    }
    const int period = span / periods;
    const float f = 1.0f / static_cast<float>(period);
    const double p = 1.0 / static_cast<double>(f);
    PhaseShiftSet set;
    set.period_px = p;
    set.steps = 3;
    // sin(x) = cos(x - pi/2); x = 2 pi f u = Phi(u) - pi f (fringe's v = u + 0.5).
    set.phase_offset_rad = -M_PI / p - M_PI / 2;
    const float shift = static_cast<float>(2 * M_PI / 3);
    for (int k = 0; k < 3; ++k) set.shifts_rad.push_back(static_cast<double>(k * shift));
    s.phase_sets = {set};
    s.quantization = Quantization::kRoundHalfEven;
    if (periods > 1) {
      s.unwrapping = Unwrapping::kSpatial;
      s.phase_retrieval = preset == "opencv-ftp"    ? PhaseRetrieval::kFtp
                          : preset == "opencv-faps" ? PhaseRetrieval::kFaps
                                                    : PhaseRetrieval::kLeastSquares;
      // Markers on by default (OpenCV's nbrOfPixelsBetweenMarkers, 56): without them the phase
      // is relative. --markers 0 gives OpenCV's setMarkers = false images.
      s.markers.spacing_px = markers >= 0 ? markers : periods >= 3 ? 56 : 0;
      s.markers.periods = periods;
      if (s.markers.Present() && periods < 3) {
        throw Error(StrCat("scheme ", preset,
                           ": OpenCV draws markers in groups of nbrOfPeriods / "
                           "3 periods: --markers needs --counts >= 3"));
      }
    } else if (markers > 0) {
      throw Error(StrCat("scheme ", preset,
                         ": one period over the span is absolute and OpenCV "
                         "draws no markers on it (nbrOfPeriods / 3 = 0): --markers applies to "
                         "--counts >= 3"));
    }
    for (int i = 0; i < 3; ++i) t.frames.push_back(i);
    t.names = "%d.png";
  } else if (preset == "slmaster-sinus-comple-gray") {
    // SLMaster (github.com/Practice3DVision/SLMaster, src/algorithm/cpuStructuredLight/
    // sinusCompleGraycodePattern.cpp, revision 58e73231): shiftTime steps of
    // uchar(127.5 + 127.5 cos(2 pi (u mod P) / P - pi + 2 pi i / N)) in double (truncated),
    // P = span / nbrOfPeriods, then log2(nbrOfPeriods) + 1 images of the reflected binary
    // sequence over blocks of span / 2^(i+1) px: the Gray code of the period with the
    // complementary half-period bit last, thresholded by the mean of the phase images.
    const int periods = count > 0 ? static_cast<int>(count) : 32;
    const int n = steps > 0 ? steps : 4;
    const int bits = CeilLog2(std::max(periods, 1));
    if (count != std::floor(count) || periods < 2 || (1 << bits) != periods ||
        span % periods != 0 || (span / periods) % 2 != 0) {
      throw Error(StrCat("scheme ", preset,
                         ": SLMaster's Gray code aligns with its periods only for a power-of-two "
                         "number of periods (--counts, got ",
                         periods, ") dividing the span of ", span, " px into even periods"));
    }
    const int period = span / periods;
    PhaseShiftSet set;
    set.period_px = period;
    set.steps = n;
    set.phase_offset_rad = -M_PI - M_PI / period;
    for (int i = 0; i < n; ++i) set.shifts_rad.push_back(2 * M_PI / n * i);
    s.phase_sets = {set};
    s.gray_bits = bits;
    s.gray_complementary = true;
    s.quantization = Quantization::kFloor;
    for (int i = 0; i < s.NumImages(); ++i) t.frames.push_back(i);
    t.names = "%02d.png";  // SLMaster's GUI names its files itself: give --image-names
  } else if (preset == "slmaster-three-frequency-heterodyne") {
    // SLMaster (src/algorithm/cpuStructuredLight/threeFrequencyHeterodynePattern.cpp, 58e73231,
    // generator unchanged in f300566f): shiftTime steps at each of nbrOfPeriods, nbrOfPeriods - 6
    // and nbrOfPeriods - 11 periods over the span (beats of span / 6 and span / 5, beat of beats
    // the span), uchar(127.5 + 127.5 cos(fl((2 d - 1) pi) + fl(2 pi i / N))) with d the fraction
    // of the period in single precision (Arithmetic::kFloat32Wrapped).
    const int periods = count > 0 ? static_cast<int>(count) : 32;
    const int n = steps > 0 ? steps : 4;
    if (count != std::floor(count) || periods < 12 || periods > span / 3) {
      throw Error(StrCat("scheme ", preset,
                         ": nbrOfPeriods (--counts) must be a whole number in [12, span / 3] "
                         "(its third set has nbrOfPeriods - 11 periods; got ",
                         count, ")"));
    }
    for (const int weeks : {periods, periods - 6, periods - 11}) {
      PhaseShiftSet set;
      set.period_px = static_cast<double>(span) / weeks;
      set.steps = n;
      set.phase_offset_rad = -M_PI - M_PI / set.period_px;
      for (int i = 0; i < n; ++i) set.shifts_rad.push_back(2 * M_PI / n * i);  // CV_2PI / N * i
      s.phase_sets.push_back(set);
    }
    s.unwrapping = Unwrapping::kHeterodyne;
    s.quantization = Quantization::kFloor;
    s.arithmetic = Arithmetic::kFloat32Wrapped;
    for (int i = 0; i < s.NumImages(); ++i) t.frames.push_back(i);
    t.names = "%02d.png";  // SLMaster's GUI names its files itself: give --image-names
  } else {
    throw Error(StrCat("unknown tool codec '", preset, "'"));
  }
  return t;
}

bool IsToolPreset(const std::string& preset) {
  for (const auto& n : ToolPresetNames()) {
    if (n == preset) return true;
  }
  return false;
}

// A printf pattern with one integer conversion applied to `numbers` (validated as names).
std::vector<std::string> FormatNames(const std::string& spec, const std::vector<int>& numbers) {
  const size_t pos = spec.find('%');
  size_t end = pos + 1;
  while (end < spec.size() && std::isdigit(static_cast<unsigned char>(spec[end]))) ++end;
  if (pos == std::string::npos || end >= spec.size() || spec[end] != 'd' ||
      spec.find('%', end) != std::string::npos || end - pos > 3) {
    throw Error(
        StrCat("--image-names '", spec, "': expected one integer conversion such as %d or %02d"));
  }
  std::vector<std::string> names;
  for (const int n : numbers) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), spec.substr(pos, end + 1 - pos).c_str(), n);
    names.push_back(spec.substr(0, pos) + buf + spec.substr(end + 1));
  }
  util::CheckRelativeNames(names, "--image-names", util::ImageExtensions(), "image name");
  return names;
}

}  // namespace

std::vector<std::string> ToolPresetNames() {
  return {"slstudio-phaseshift2x3",
          "slstudio-phaseshift3",
          "slstudio-phaseshift4",
          "slstudio-phaseshift3fastwrap",
          "slstudio-phaseshift2p1",
          "slstudio-phaseshiftnstep",
          "slstudio-graycode",
          "opencv-graycode",
          "opencv-psp",
          "opencv-ftp",
          "opencv-faps",
          "slmaster-sinus-comple-gray",
          "slmaster-three-frequency-heterodyne"};
}

std::vector<std::string> AllPresetNames() {
  std::vector<std::string> names = SchemePresetNames();
  for (const auto& n : ToolPresetNames()) names.push_back(n);
  return names;
}

bool SchemeParameters::AnySet() const {
  return projector_width > 0 || projector_height > 0 || horizontal || period_px > 0 ||
         !counts.empty() || steps > 0 || gray_bits >= 0 || !std::isnan(phase_offset_rad) ||
         !image_names.empty() || markers >= 0;
}

void SchemeParameters::Check() const {
  const char* o = "scheme parameters";
  CheckOption(projector_width >= 0 && projector_width <= util::kMaxImageSidePx, o, "width",
              projector_width, "must be in [1, 32768]");
  CheckOption(projector_height >= 0 && projector_height <= util::kMaxImageSidePx, o, "height",
              projector_height, "must be in [1, 32768]");
  CheckOption(period_px == 0 || (std::isfinite(period_px) && period_px > 2), o, "period", period_px,
              "must be > 2 projector pixels");
  for (double c : counts) {
    CheckOption(std::isfinite(c) && c >= 1, o, "counts", c, "must be >= 1 fringe over the span");
  }
  CheckOption(steps == 0 || (steps >= 3 && steps <= kMaxSteps), o, "steps", steps,
              "must be in [3, 64]");
  CheckOption(gray_bits == -1 || (gray_bits >= 1 && gray_bits <= 16), o, "gray-bits", gray_bits,
              "must be in [1, 16]");
  CheckOption(std::isnan(phase_offset_rad) || std::isfinite(phase_offset_rad), o, "phase-offset",
              phase_offset_rad, "must be finite");
  CheckOption(markers == -1 || markers == 0 || (markers >= 3 && markers <= util::kMaxImageSidePx),
              o, "markers", markers, "must be 0 (none) or a spacing in [3, 32768] px");
}

std::vector<std::string> ExpandImageNames(const std::string& spec, int n) {
  std::vector<std::string> names;
  if (spec.find('%') != std::string::npos) {
    // Exactly one integer conversion, nothing else that printf would interpret.
    std::vector<int> numbers(std::max(n, 0));
    for (int i = 0; i < n; ++i) numbers[i] = i;
    return FormatNames(spec, numbers);
  } else {
    size_t start = 0;
    while (start <= spec.size()) {
      const size_t comma = std::min(spec.find(',', start), spec.size());
      names.push_back(spec.substr(start, comma - start));
      start = comma + 1;
    }
    if (static_cast<int>(names.size()) != n) {
      throw Error(
          StrCat("--image-names: ", names.size(), " names for the ", n, " images of the scheme"));
    }
  }
  util::CheckRelativeNames(names, "--image-names", util::ImageExtensions(), "image name");
  return names;
}

PatternScheme MakePresetScheme(const std::string& preset, const SchemeParameters& p) {
  p.Check();
  if (IsToolPreset(preset)) {
    // Only what the tool itself lets its user choose.
    const bool sinusoidal = preset.rfind("opencv-", 0) == 0 && preset != "opencv-graycode";
    const bool counts = sinusoidal || preset.rfind("slmaster-", 0) == 0;
    const bool steps = preset.rfind("slmaster-", 0) == 0;
    if (p.period_px > 0 || p.gray_bits >= 0 || (p.steps > 0 && !steps) ||
        !std::isnan(p.phase_offset_rad) || p.counts.size() > (counts ? 1u : 0u) ||
        (p.markers >= 0 && !sinusoidal)) {
      throw Error(StrCat("scheme ", preset,
                         ": the tool's codec fixes periods, steps, bits and offsets; give only "
                         "--width/--height, --horizontal, --image-names",
                         counts ? " and --counts (nbrOfPeriods)" : "",
                         steps ? " and --steps (shiftTime)" : "",
                         sinusoidal ? " and --markers (nbrOfPixelsBetweenMarkers, 0: none)" : ""));
    }
    ToolScheme t = MakeToolScheme(preset, p.projector_width > 0 ? p.projector_width : 1280,
                                  p.projector_height > 0 ? p.projector_height : 800, p.horizontal,
                                  p.counts.empty() ? 0 : p.counts[0], p.steps, p.markers);
    PatternScheme& s = t.scheme;
    // A printf pattern numbers the tool's own frames; a list names the stack's images.
    const std::string spec = p.image_names.empty() ? t.names : p.image_names;
    s.image_names = spec.find('%') != std::string::npos ? FormatNames(spec, t.frames)
                                                        : ExpandImageNames(spec, s.NumImages());
    try {
      s.Check();
    } catch (const Error& e) {
      throw Error(StrCat("scheme ", preset, ": ", e.what()));
    }
    return s;
  }
  const bool slsdk = preset == "slsdk-phasegray";
  const int gray_steps = slsdk ? 4 : GrayFamilySteps(preset);
  PatternScheme s;
  if (gray_steps > 0) {
    // The alias's own values first; every parameter given overrides them.
    const PatternScheme base = slsdk ? MakeScheme("slsdk-phasegray") : PatternScheme();
    s.name = preset;
    s.projector_width = p.projector_width > 0 ? p.projector_width
                        : slsdk               ? base.projector_width
                                              : 1280;
    s.projector_height = p.projector_height > 0 ? p.projector_height
                         : slsdk                ? base.projector_height
                                                : 800;
    s.direction = p.horizontal ? FringeDirection::kHorizontal : FringeDirection::kVertical;
    const double span = s.Span();
    PhaseShiftSet set;
    set.steps = p.steps > 0 ? p.steps : gray_steps;
    set.phase_offset_rad = !std::isnan(p.phase_offset_rad) ? p.phase_offset_rad
                           : slsdk                         ? base.phase_sets[0].phase_offset_rad
                                                           : 0.0;
    int bits = p.gray_bits;
    if (p.period_px > 0) {
      set.period_px = p.period_px;
    } else if (slsdk && p.projector_width == 0 && p.projector_height == 0 && bits < 0) {
      set.period_px = base.phase_sets[0].period_px;
    } else if (bits > 0) {
      set.period_px = span / std::ldexp(1.0, bits);
    } else {
      bits = 1;
      while (span / std::ldexp(1.0, bits) > 32.0) ++bits;
      set.period_px = span / std::ldexp(1.0, bits);
    }
    if (bits < 0) {
      // The fewest bits that count every period of the span.
      bits = 1;
      while (std::ldexp(1.0, bits) * set.period_px < span && bits < 16) ++bits;
    }
    s.phase_sets.push_back(set);
    s.gray_bits = bits;
    s.gray_complementary = true;
    // The capture's own names while the image count is the capture's (a new size or period can
    // change the number of Gray bits).
    if (slsdk && p.image_names.empty() && s.NumImages() == base.NumImages()) {
      s.image_names = base.image_names;
    }
  } else if (IsHeterodynePreset(preset)) {
    if (p.period_px > 0 || p.gray_bits >= 0) {
      throw Error(StrCat("scheme ", preset,
                         ": --period and --gray-bits apply to gray+N schemes; give fringe counts "
                         "with --counts"));
    }
    const int w = p.projector_width > 0 ? p.projector_width : 1280;
    const int h = p.projector_height > 0 ? p.projector_height : 800;
    s = p.horizontal ? MakeScheme(preset, h, w) : MakeScheme(preset, w, h);
    s.projector_width = w;
    s.projector_height = h;
    s.direction = p.horizontal ? FringeDirection::kHorizontal : FringeDirection::kVertical;
    if (!p.counts.empty()) {
      if (p.counts.size() != s.phase_sets.size()) {
        throw Error(StrCat("scheme ", preset, ": --counts gives ", p.counts.size(),
                           " fringe counts for ", s.phase_sets.size(), " phase sets"));
      }
      for (size_t i = 0; i < p.counts.size(); ++i) {
        s.phase_sets[i].period_px = s.Span() / p.counts[i];
      }
    }
    for (auto& set : s.phase_sets) {
      if (p.steps > 0) {
        set.steps = p.steps;
        set.shifts_rad.clear();
      }
      if (!std::isnan(p.phase_offset_rad)) set.phase_offset_rad = p.phase_offset_rad;
    }
  } else {
    return MakeScheme(preset);  // throws, listing the presets
  }
  if (!p.image_names.empty()) s.image_names = ExpandImageNames(p.image_names, s.NumImages());
  try {
    s.Check();
  } catch (const Error& e) {
    throw Error(StrCat("scheme ", preset, ": ", e.what()));
  }
  return s;
}

PatternScheme SchemeFromArgument(const std::string& name_or_path, const SchemeParameters& p) {
  const bool preset = GrayFamilySteps(name_or_path) > 0 || IsHeterodynePreset(name_or_path) ||
                      name_or_path == "slsdk-phasegray" || IsToolPreset(name_or_path);
  if (preset) return MakePresetScheme(name_or_path, p);
  if (p.AnySet()) {
    throw Error(StrCat(name_or_path,
                       ": scheme parameters (--width, --period, --counts, ...) apply to presets; a "
                       "manifest file describes the whole scheme"));
  }
  if (std::filesystem::exists(name_or_path)) return SchemeFromNameOrFile(name_or_path);
  try {
    return SchemeFromNameOrFile(name_or_path);  // throws: a missing file or an unknown preset
  } catch (const Error& e) {
    std::string tools;
    for (const auto& n : ToolPresetNames()) tools += StrCat(tools.empty() ? "" : ", ", n);
    throw Error(StrCat(e.what(), "; other tools' codecs: ", tools));
  }
}

}  // namespace fringe::phase
