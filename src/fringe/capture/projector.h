// The projector: a borderless window covering one screen exactly, showing 8-bit pattern images
// pixel for pixel (no scaling, no filtering, no colour management) through SDL2, presented with
// vsync. The projector is whatever display output the screen is — an X11 screen (":0.1") or an
// output of the current display ("HDMI-1", or its index "1").
//
// Thread safety: one Projector per process (SDL's video subsystem is process-wide), used from
// the thread that opened it.
#pragma once

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace fringe::capture {

struct ScreenInfo {
  std::string display;  // the X11 display the screen belongs to (":0")
  std::string name;     // SDL's display name (the output name on X11 with RandR)
  int index = 0;        // SDL display index on `display`
  int x = 0, y = 0, width = 0, height = 0;  // bounds, px
  double refresh_hz = 0;                    // 0 when unknown
};
nlohmann::json ToJson(const ScreenInfo& screen);

// The screens of an X11 display (empty: $DISPLAY). Throws fringe::Error when the display cannot
// be opened.
std::vector<ScreenInfo> ListScreens(const std::string& display = "");

class Projector {
 public:
  using Clock = std::chrono::steady_clock;

  // Opens a window covering `screen` exactly:
  //   ":N" / ":N.S" / "host:N.S" — that X11 display and screen (SDL display 0 of it);
  //   "K" — SDL display K of $DISPLAY; any other text — the display of that name on $DISPLAY.
  // Throws fringe::Error naming the screen when it does not exist, and when its size is not
  // width x height (the scheme's projector size: patterns are shown pixel for pixel, never
  // scaled).
  static std::unique_ptr<Projector> Open(const std::string& screen, int width, int height);
  ~Projector();
  Projector(const Projector&) = delete;
  Projector& operator=(const Projector&) = delete;

  // Shows an 8-bit single-channel image of the screen's size and returns after it was
  // presented (SDL_RenderPresent with vsync returns after the buffer swap); the time it
  // returned is the pattern's presentation time. Throws fringe::Error on a wrong size/type.
  Clock::time_point Show(const cv::Mat& image);
  // A uniform frame (0 = black, 255 = white).
  Clock::time_point ShowLevel(int level);

  const ScreenInfo& screen() const { return screen_; }
  const std::string& spec() const { return spec_; }
  // The SDL renderer in use ("opengl", "software", ...).
  const std::string& renderer() const { return renderer_name_; }

 private:
  Projector() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  ScreenInfo screen_;
  std::string spec_;
  std::string renderer_name_;
};

}  // namespace fringe::capture
