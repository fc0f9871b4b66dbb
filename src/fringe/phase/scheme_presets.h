// Parameterised scheme presets: the projector size, periods (or fringe counts for multi-frequency
// schemes), steps, Gray bits, phase offset and image names of a capture given on the command
// line, with the same flag names on `fringe patterns`, `decode` and `reconstruct`
// (cli/scheme_flags.h), instead of a manifest file.
//
//   gray+N            N-step phase shift (N >= 3) + Gray code + complementary Gray bit. Period
//                     span / 2^bits with the fewest bits giving <= 32 px, unless --period and/or
//                     --gray-bits say otherwise.
//   slsdk-phasegray   alias of gray+4 with the parameters of ../shared/data/slsdk-stereo-phasegray
//                     (1920x1080, period 60 px, offset -pi, 5 bits, images 0.png ... 9.png); any
//                     parameter given overrides the alias's value.
//   heterodyne-4x3, thesis-4+3+3, heterodyne-3x3
//                     three frequencies; --counts A,B,C sets the number of fringes over the
//                     projector span (periods span/A, span/B, span/C; default 70,64,59 over 1.25
//                     x span, pattern_scheme.h).
//   slstudio-*, opencv-*, slmaster-* (ToolPresetNames)
//                     other tools' codecs (docs/formats.md, "Other tools' codecs"), their images
//                     byte for byte as the tool makes them, in the tool's order and with its file
//                     names; only --width/--height, --horizontal and --image-names apply, plus
//                     what the tool lets its user choose: opencv-psp/ftp/faps --counts
//                     (nbrOfPeriods) and --markers (nbrOfPixelsBetweenMarkers), slmaster-*
//                     --counts (nbrOfPeriods) and --steps (shiftTime). A printf --image-names
//                     numbers the tool's own frames (pattern_cam2_im%d.png for OpenCV's second
//                     camera).
// Thread safety: pure functions.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "fringe/phase/pattern_scheme.h"

namespace fringe::phase {

// Unset fields (0, -1, NaN, empty) keep the preset's value.
struct SchemeParameters {
  int projector_width = 0;     // projector pixels, (0, 32768]
  int projector_height = 0;    // projector pixels, (0, 32768]
  bool horizontal = false;     // horizontal fringes (phase along projector rows)
  double period_px = 0;        // gray+N: period of the phase set, projector pixels, > 2
  std::vector<double> counts;  // heterodyne presets: fringes over the span, one per set
  int steps = 0;               // gray+N: overrides N; heterodyne: steps of every set, [3, 64]
  int gray_bits = -1;          // gray+N: Gray bits, [1, 16]
  double phase_offset_rad = std::numeric_limits<double>::quiet_NaN();  // added to every set
  // OpenCV's SinusoidalPattern presets: marker spacing (nbrOfPixelsBetweenMarkers; 0 = none,
  // -1 = the preset's default, 56 px when there are 3 or more periods).
  int markers = -1;
  // Image names: a printf pattern with one integer conversion ("%d.png", "img_%02d.bmp") or a
  // comma-separated list naming every image in stack order.
  std::string image_names;

  bool AnySet() const;
  void Check() const;
};

// A preset with parameters; the result is Check()ed. Throws fringe::Error naming the preset or
// parameter.
PatternScheme MakePresetScheme(const std::string& preset, const SchemeParameters& parameters);

// A preset name (with parameters) or a manifest file (parameters must then be unset: the
// manifest is the whole description). A path-like name that does not exist is reported as a
// missing file.
PatternScheme SchemeFromArgument(const std::string& name_or_path,
                                 const SchemeParameters& parameters);

// The presets of other tools' codecs.
std::vector<std::string> ToolPresetNames();
// Every preset name: fringe's own (SchemePresetNames; gray+4 stands for the gray+N family), then
// the other tools' codecs.
std::vector<std::string> AllPresetNames();

// Expands SchemeParameters::image_names for n images (validated as names inside a folder).
std::vector<std::string> ExpandImageNames(const std::string& spec, int n);

}  // namespace fringe::phase
