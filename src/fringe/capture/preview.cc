#include "fringe/capture/preview.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <opencv2/imgproc.hpp>

#include "fringe/capture/projector.h"
#include "fringe/util/error.h"

// Xlib last: its macros (None, Status, Bool) would clash with the headers above.
#include <X11/Xlib.h>
#include <X11/Xutil.h>
#include <X11/keysym.h>

namespace fringe::capture {
namespace {

using util::StrCat;

// The operator's window: plain Xlib on its own connection, so it can live on another X display
// than the projector's (SDL's video subsystem holds one display per process).
class PreviewWindow {
 public:
  explicit PreviewWindow(const std::string& screen) {
    display_ = XOpenDisplay(screen.empty() ? nullptr : screen.c_str());
    if (display_ == nullptr) {
      throw Error(StrCat("preview: cannot open the preview screen '",
                         screen.empty() ? "$DISPLAY" : screen,
                         "' (give --preview-screen, an X11 display such as :0)"));
    }
  }
  ~PreviewWindow() {
    if (window_ != 0) XDestroyWindow(display_, window_);
    XCloseDisplay(display_);
  }
  PreviewWindow(const PreviewWindow&) = delete;
  PreviewWindow& operator=(const PreviewWindow&) = delete;

  // Shows a CV_8UC3 BGR image (the window is created, or resized, to its size).
  void Show(const cv::Mat& bgr) {
    const int screen = DefaultScreen(display_);
    if (window_ == 0) {
      window_ =
          XCreateSimpleWindow(display_, RootWindow(display_, screen), 0, 0, bgr.cols, bgr.rows, 0,
                              BlackPixel(display_, screen), BlackPixel(display_, screen));
      XStoreName(display_, window_,
                 "fringe capture --preview (w: white, f: focus, c: crosshair, q: quit)");
      XSelectInput(display_, window_, KeyPressMask | StructureNotifyMask);
      delete_atom_ = XInternAtom(display_, "WM_DELETE_WINDOW", False);
      XSetWMProtocols(display_, window_, &delete_atom_, 1);
      XMapWindow(display_, window_);
      gc_ = DefaultGC(display_, screen);
      size_ = bgr.size();
    } else if (size_ != bgr.size()) {
      XResizeWindow(display_, window_, bgr.cols, bgr.rows);
      size_ = bgr.size();
    }
    // ZPixmap of a 24-bit TrueColor visual: 32 bits per pixel, blue in the low byte — BGRA.
    cv::cvtColor(bgr, bgra_, cv::COLOR_BGR2BGRA);
    Visual* visual = DefaultVisual(display_, screen);
    XImage* image =
        XCreateImage(display_, visual, DefaultDepth(display_, screen), ZPixmap, 0,
                     reinterpret_cast<char*>(bgra_.data), bgra_.cols, bgra_.rows, 32, 0);
    if (image == nullptr) throw Error("preview: XCreateImage failed");
    XPutImage(display_, window_, gc_, image, 0, 0, 0, 0, bgra_.cols, bgra_.rows);
    image->data = nullptr;  // owned by bgra_
    XDestroyImage(image);
    XFlush(display_);
  }

  // Handles the pending events: a pattern key switches the pattern, q / Esc / closing the
  // window returns false.
  bool Poll(PreviewPattern* pattern) {
    while (XPending(display_) > 0) {
      XEvent e;
      XNextEvent(display_, &e);
      if (e.type == ClientMessage && static_cast<Atom>(e.xclient.data.l[0]) == delete_atom_) {
        return false;
      }
      if (e.type == KeyPress) {
        const KeySym key = XLookupKeysym(&e.xkey, 0);
        if (key == XK_q || key == XK_Escape) return false;
        if (key == XK_w) *pattern = PreviewPattern::kWhite;
        if (key == XK_f) *pattern = PreviewPattern::kFocus;
        if (key == XK_c) *pattern = PreviewPattern::kCrosshair;
      }
    }
    return true;
  }

 private:
  Display* display_ = nullptr;
  Window window_ = 0;
  GC gc_ = nullptr;
  Atom delete_atom_ = 0;
  cv::Size size_;
  cv::Mat bgra_;
};

// One camera's tile of the window: the frame as 8 bit, saturated pixels red, the figures on top.
cv::Mat Tile(const Frame& frame, const PreviewFigures& f, int width) {
  cv::Mat grey;
  frame.image.convertTo(grey, CV_8U, 255.0 / (std::ldexp(1.0, frame.bit_depth) - 1));
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  const double full = std::ldexp(1.0, frame.bit_depth) - 1;
  bgr.setTo(cv::Scalar(0, 0, 255), frame.image >= full);
  if (bgr.cols != width) {
    cv::resize(bgr, bgr, cv::Size(width, bgr.rows * width / bgr.cols), 0, 0, cv::INTER_NEAREST);
  }
  const std::string lines[] = {
      StrCat(f.camera, " ", f.id),
      StrCat("saturated ", std::round(f.saturated_pct * 100) / 100, " %"),
      StrCat("focus ", f.focus),
      StrCat("lit ", std::round(f.lit_fraction * 1000) / 10, " %"),
  };
  int y = 18;
  for (const auto& line : lines) {
    cv::putText(bgr, line, {6, y}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0}, 3);
    cv::putText(bgr, line, {6, y}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 255, 0}, 1);
    y += 20;
  }
  return bgr;
}

}  // namespace

PreviewPattern ParsePreviewPattern(const std::string& name) {
  if (name == "white") return PreviewPattern::kWhite;
  if (name == "focus") return PreviewPattern::kFocus;
  if (name == "crosshair") return PreviewPattern::kCrosshair;
  throw Error(StrCat("preview pattern '", name, "': expected white, focus or crosshair"));
}

std::string PreviewPatternName(PreviewPattern pattern) {
  switch (pattern) {
    case PreviewPattern::kWhite:
      return "white";
    case PreviewPattern::kFocus:
      return "focus";
    case PreviewPattern::kCrosshair:
      return "crosshair";
  }
  return "white";
}

cv::Mat PreviewPatternImage(PreviewPattern pattern, int width, int height) {
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(0));
  switch (pattern) {
    case PreviewPattern::kWhite:
      image.setTo(255);
      break;
    case PreviewPattern::kFocus:
      for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
          image.at<uint8_t>(y, x) = ((x / 4 + y / 4) % 2) ? 255 : 0;
        }
      }
      break;
    case PreviewPattern::kCrosshair:
      cv::rectangle(image, {0, 0}, {width - 1, height - 1}, cv::Scalar(255), 1);
      cv::rectangle(image, {0, height / 2 - 1}, {width - 1, height / 2 + 1}, cv::Scalar(255),
                    cv::FILLED);
      cv::rectangle(image, {width / 2 - 1, 0}, {width / 2 + 1, height - 1}, cv::Scalar(255),
                    cv::FILLED);
      break;
  }
  return image;
}

double FocusMeasure(const cv::Mat& image, int bit_depth) {
  cv::Mat f, laplacian;
  image.convertTo(f, CV_32F, 1.0 / (std::ldexp(1.0, bit_depth) - 1));
  cv::Laplacian(f, laplacian, CV_32F, 1);
  cv::Scalar mean, stddev;
  cv::meanStdDev(laplacian, mean, stddev);
  return stddev[0] * stddev[0];
}

void PreviewOptions::Check() const {
  util::CheckOption(!left.empty(), "PreviewOptions", "left", left, "must name a camera");
  util::CheckOption(!projector.empty(), "PreviewOptions", "projector", projector,
                    "must name a screen");
  util::CheckOption(projector_width > 0 && projector_height > 0, "PreviewOptions",
                    "projector_width", projector_width, "the projector size must be positive");
  util::CheckOption(frames >= 0, "PreviewOptions", "frames", frames, "must be >= 0");
  util::CheckOption(min_lit_contrast > 0 && min_lit_contrast < 1, "PreviewOptions",
                    "min_lit_contrast", min_lit_contrast, "must be in (0, 1)");
  sequence.Check();
}

nlohmann::json ToJson(const PreviewResult& r) {
  nlohmann::json cams = nlohmann::json::array();
  for (const auto& f : r.cameras) {
    cams.push_back({{"camera", f.camera},
                    {"id", f.id},
                    {"saturated_pct", f.saturated_pct},
                    {"saturated_lit_pct", f.saturated_lit_pct},
                    {"focus", f.focus},
                    {"lit_fraction", f.lit_fraction}});
  }
  return {{"preview",
           {{"pattern", r.pattern},
            {"refreshes", r.refreshes},
            {"seconds", r.seconds},
            {"cameras", cams}}}};
}

PreviewResult RunPreview(const PreviewOptions& options) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  // The projector first and the window next: a missing screen is found before any camera is
  // touched, as in capture.
  std::unique_ptr<Projector> projector =
      Projector::Open(options.projector, options.projector_width, options.projector_height);
  PreviewWindow window(options.preview_screen);
  std::vector<std::unique_ptr<Camera>> owned;
  // Stops every camera opened so far on the way out, also when the next one fails to open.
  struct StopCameras {
    std::vector<std::unique_ptr<Camera>>* owned;
    ~StopCameras() {
      for (auto& c : *owned) {
        try {
          c->Stop();
        } catch (...) {
          // Closing after an error: the first error is the one reported.
        }
      }
    }
  } stop{&owned};
  std::vector<Camera*> cameras;
  std::vector<std::string> names;
  for (const std::string& spec : {options.left, options.right}) {
    if (spec.empty()) continue;
    owned.push_back(OpenCamera(spec));
    owned.back()->Configure(options.camera);
    owned.back()->Start();
    cameras.push_back(owned.back().get());
    names.push_back(owned.size() == 1 ? "left" : "right");
  }

  PreviewResult r;
  PreviewPattern pattern = options.pattern;
  const int tile_width = std::min(640, cameras[0]->Info().width);
  while (options.frames == 0 || r.refreshes < options.frames) {
    if (!window.Poll(&pattern)) break;
    const cv::Mat image =
        PreviewPatternImage(pattern, options.projector_width, options.projector_height);
    const std::vector<Frame> black = CaptureLevel(cameras, *projector, 0, options.sequence);
    StackCapture live = CaptureStack(cameras, *projector, {image}, options.sequence);
    std::vector<Frame> white;
    if (pattern == PreviewPattern::kWhite) {
      for (auto& f : live.frames) white.push_back(f[0]);
    } else {
      white = CaptureLevel(cameras, *projector, 255, options.sequence);
    }
    r.cameras.clear();
    std::vector<cv::Mat> tiles;
    for (size_t i = 0; i < cameras.size(); ++i) {
      const Frame& frame = live.frames[i][0];
      const LitPixels lit = ClassifyLit(black[i], white[i], options.min_lit_contrast);
      PreviewFigures f;
      f.camera = names[i];
      f.id = cameras[i]->Info().id;
      const double full = std::ldexp(1.0, frame.bit_depth) - 1;
      f.saturated_pct =
          100.0 * cv::countNonZero(frame.image >= full) / static_cast<double>(frame.image.total());
      f.saturated_lit_pct = 100.0 * lit.saturated_fraction;
      f.focus = FocusMeasure(frame.image, frame.bit_depth);
      f.lit_fraction = lit.lit_fraction;
      r.cameras.push_back(f);
      tiles.push_back(Tile(frame, f, tile_width));
    }
    // Side by side; tiles of different heights are padded.
    int height = 0;
    for (const auto& t : tiles) height = std::max(height, t.rows);
    for (auto& t : tiles) {
      if (t.rows < height) {
        cv::Mat padded;
        cv::copyMakeBorder(t, padded, 0, height - t.rows, 0, 0, cv::BORDER_CONSTANT, {0, 0, 0});
        t = padded;
      }
    }
    cv::Mat canvas;
    cv::hconcat(tiles, canvas);
    window.Show(canvas);
    r.pattern = PreviewPatternName(pattern);
    ++r.refreshes;
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace fringe::capture
