// `fringe capture --preview`: setting up the sensor. Both cameras live in a window on the
// operator's screen (an X11 window, not the projector's SDL window: the two are on different
// screens, often different X displays), with the pixels saturated under the projector's current
// frame marked red and per camera a focus measure and the fraction of the image the projector
// lights. The projector meanwhile shows white, a focus pattern or a crosshair. Nothing is
// written anywhere.
//
// Every refresh: a black frame (the reference of the lit classification), the live frame under
// the chosen pattern, and — when the pattern is not white — a white frame; the lit pixels are
// classified as --auto-exposure does (ClassifyLit). The black frame makes the projector flicker
// once per refresh; that is the price of a lit fraction that follows the sensor as it is aimed.
//
// Thread safety: one preview per process (it opens the Projector).
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/capture/camera.h"
#include "fringe/capture/sequence.h"

namespace fringe::capture {

enum class PreviewPattern { kWhite, kFocus, kCrosshair };
// "white" | "focus" | "crosshair"; throws fringe::Error for anything else.
PreviewPattern ParsePreviewPattern(const std::string& name);
std::string PreviewPatternName(PreviewPattern pattern);
// The projector image of a pattern: uniform white; a checkerboard of 4-pixel squares (pixel-
// sharp edges everywhere, so blur anywhere in the projector's area lowers the focus measure);
// a 3-pixel crosshair through the centre with a 1-pixel frame on the border (aiming: both
// cameras should see the centre and the border).
cv::Mat PreviewPatternImage(PreviewPattern pattern, int width, int height);

// The focus measure: the variance of the Laplacian (3x3) of the image scaled to [0, 1] of full
// scale, over the whole image. It is the classic autofocus figure (Pech-Pacheco et al. 2000):
// one filter, no threshold to tune (gradient-energy measures like Tenengrad need one to ignore
// noise), and its value grows monotonically as the edges of a fixed scene sharpen. It depends on
// the scene and the pattern, so it is a relative figure: compare it while turning the focus
// ring, under the same pattern (the focus pattern gives the most edges), not between setups.
double FocusMeasure(const cv::Mat& image, int bit_depth);

struct PreviewOptions {
  std::string left, right;  // camera specs (OpenCamera); right empty: one camera
  std::string projector;    // projector screen (Projector::Open)
  int projector_width = 0, projector_height = 0;  // the scheme's projector size
  // The operator's X11 display for the window (empty: $DISPLAY).
  std::string preview_screen;
  CameraSettings camera;
  SequenceOptions sequence;
  PreviewPattern pattern = PreviewPattern::kWhite;
  // Refreshes before returning; 0: until the window is closed or q / Esc is pressed.
  int frames = 0;
  double min_lit_contrast = AutoExposureOptions().min_lit_contrast;
  void Check() const;
};

struct PreviewFigures {
  std::string camera;  // "left" | "right"
  std::string id;      // the camera's id
  // Pixels at full scale in the live frame (under the current pattern), % of the image: the ones
  // marked red.
  double saturated_pct = 0;
  // Lit pixels saturated under white, % of the lit pixels (--auto-exposure's criterion: at most
  // 0.1 %).
  double saturated_lit_pct = 0;
  double focus = 0;         // FocusMeasure of the live frame
  double lit_fraction = 0;  // pixels the projector lights (white vs black), of the image
};

struct PreviewResult {
  std::vector<PreviewFigures> cameras;  // the last refresh's figures
  std::string pattern;                  // the last refresh's pattern
  int refreshes = 0;
  double seconds = 0;
};
nlohmann::json ToJson(const PreviewResult& result);

// Opens the projector, the cameras and the window, and refreshes until options.frames refreshes
// were made (or the window is closed). Throws fringe::Error naming the device when a camera or a
// screen does not exist, and the step when a frame does not come.
PreviewResult RunPreview(const PreviewOptions& options);

}  // namespace fringe::capture
