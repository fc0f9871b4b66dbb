// The scheme-parameter flags shared by `fringe patterns`, `decode` and `reconstruct`: one
// spelling for one quantity across commands (phase/scheme_presets.h).
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "fringe/phase/scheme_presets.h"
#include "fringe/util/error.h"

namespace fringe::cli {

inline void AddSchemeFlags(CLI::App* sub, phase::SchemeParameters* p) {
  sub->add_option("--width", p->projector_width, "Projector width in pixels (presets)")
      ->check(CLI::Range(1, 1 << 15));
  sub->add_option("--height", p->projector_height, "Projector height in pixels (presets)")
      ->check(CLI::Range(1, 1 << 15));
  sub->add_flag("--horizontal", p->horizontal,
                "Horizontal fringes (phase along projector rows; presets)");
  sub->add_option("--period", p->period_px, "gray+N: fringe period in projector pixels")
      ->check(CLI::Range(2.0, 1e5));
  sub->add_option("--counts", p->counts,
                  "Heterodyne presets: fringes over the projector span, one per set (e.g. "
                  "70,64,59); opencv-psp/ftp/faps, slmaster-*: the tool's nbrOfPeriods")
      ->delimiter(',');
  sub->add_option("--steps", p->steps, "Phase steps per set (presets; slmaster-*: shiftTime)")
      ->check(CLI::Range(3, 64));
  sub->add_option("--gray-bits", p->gray_bits, "gray+N: number of Gray-code bits")
      ->check(CLI::Range(1, 16));
  sub->add_option("--phase-offset", p->phase_offset_rad,
                  "Constant added to every step's phase, radians (e.g. -3.14159 when the capture "
                  "tool's wrapped phase is -pi at the start of a period)");
  sub->add_option("--markers", p->markers,
                  "opencv-psp/ftp/faps: OpenCV's marker spacing (nbrOfPixelsBetweenMarkers, "
                  "default 56 with 3 or more periods; 0: no markers, as OpenCV's setMarkers = "
                  "false, which leaves the phase relative)")
      ->check(CLI::Range(0, 1 << 15));
  sub->add_option("--image-names", p->image_names,
                  "Image file names: a pattern with one integer (%d.png, img_%02d.bmp) or a "
                  "comma-separated list in stack order; with another tool's preset the integer "
                  "numbers that tool's frames (pattern_cam2_im%d.png)");
}

}  // namespace fringe::cli
