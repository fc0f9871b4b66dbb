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

}  // namespace

bool SchemeParameters::AnySet() const {
  return projector_width > 0 || projector_height > 0 || horizontal || period_px > 0 ||
         !counts.empty() || steps > 0 || gray_bits >= 0 || !std::isnan(phase_offset_rad) ||
         !image_names.empty();
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
}

std::vector<std::string> ExpandImageNames(const std::string& spec, int n) {
  std::vector<std::string> names;
  if (spec.find('%') != std::string::npos) {
    // Exactly one integer conversion, nothing else that printf would interpret.
    const size_t pos = spec.find('%');
    size_t end = pos + 1;
    while (end < spec.size() && std::isdigit(static_cast<unsigned char>(spec[end]))) ++end;
    if (end >= spec.size() || spec[end] != 'd' || spec.find('%', end) != std::string::npos ||
        end - pos > 3) {
      throw Error(
          StrCat("--image-names '", spec, "': expected one integer conversion such as %d or %02d"));
    }
    const std::string suffix = spec.substr(end + 1);
    for (int i = 0; i < n; ++i) {
      char buf[64];
      std::snprintf(buf, sizeof(buf), spec.substr(pos, end + 1 - pos).c_str(), i);
      names.push_back(spec.substr(0, pos) + buf + suffix);
    }
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
    if (slsdk && p.image_names.empty() && set.steps == 4) s.image_names = base.image_names;
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
                      name_or_path == "slsdk-phasegray";
  if (preset) return MakePresetScheme(name_or_path, p);
  if (p.AnySet()) {
    throw Error(StrCat(name_or_path,
                       ": scheme parameters (--width, --period, --counts, ...) apply to presets; a "
                       "manifest file describes the whole scheme"));
  }
  return SchemeFromNameOrFile(name_or_path);
}

}  // namespace fringe::phase
