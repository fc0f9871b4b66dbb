#include "fringe/capture/projector.h"

#include <SDL.h>

#include <cstdlib>
#include <opencv2/imgproc.hpp>

#include "fringe/util/error.h"

namespace fringe::capture {
namespace {

using util::StrCat;

bool IsX11Display(const std::string& spec) { return spec.find(':') != std::string::npos; }

// SDL reads the X11 display from $DISPLAY when its video subsystem starts.
void InitVideo(const std::string& display) {
  if (!display.empty()) setenv("DISPLAY", display.c_str(), 1);
  SDL_SetHint(SDL_HINT_VIDEO_MINIMIZE_ON_FOCUS_LOSS, "0");
  SDL_SetHint(SDL_HINT_RENDER_SCALE_QUALITY, "nearest");
  // The projector must keep its mode and gamma: no compositor bypass tricks, no screensaver.
  SDL_SetHint(SDL_HINT_VIDEO_X11_NET_WM_BYPASS_COMPOSITOR, "0");
  if (SDL_InitSubSystem(SDL_INIT_VIDEO) != 0) {
    const char* d = std::getenv("DISPLAY");
    throw Error(StrCat("projector screen '", display.empty() ? (d ? d : "") : display,
                       "': cannot open the display: ", SDL_GetError()));
  }
}

std::vector<ScreenInfo> Screens(const std::string& display) {
  std::vector<ScreenInfo> screens;
  const int n = SDL_GetNumVideoDisplays();
  const char* d = std::getenv("DISPLAY");
  for (int k = 0; k < n; ++k) {
    ScreenInfo s;
    s.display = d ? d : display;
    const char* name = SDL_GetDisplayName(k);
    s.name = name ? name : "";
    s.index = k;
    SDL_Rect r;
    if (SDL_GetDisplayBounds(k, &r) == 0) {
      s.x = r.x;
      s.y = r.y;
      s.width = r.w;
      s.height = r.h;
    }
    SDL_DisplayMode mode;
    if (SDL_GetCurrentDisplayMode(k, &mode) == 0) s.refresh_hz = mode.refresh_rate;
    screens.push_back(s);
  }
  return screens;
}

}  // namespace

nlohmann::json ToJson(const ScreenInfo& s) {
  return {{"display", s.display},
          {"name", s.name},
          {"index", s.index},
          {"x", s.x},
          {"y", s.y},
          {"width", s.width},
          {"height", s.height},
          {"refresh_hz", s.refresh_hz}};
}

std::vector<ScreenInfo> ListScreens(const std::string& display) {
  InitVideo(display);
  auto screens = Screens(display);
  SDL_QuitSubSystem(SDL_INIT_VIDEO);
  return screens;
}

struct Projector::Impl {
  SDL_Window* window = nullptr;
  SDL_Renderer* renderer = nullptr;
  SDL_Texture* texture = nullptr;
  cv::Mat bgra;
  ~Impl() {
    if (texture) SDL_DestroyTexture(texture);
    if (renderer) SDL_DestroyRenderer(renderer);
    if (window) SDL_DestroyWindow(window);
    SDL_QuitSubSystem(SDL_INIT_VIDEO);
  }
};

std::unique_ptr<Projector> Projector::Open(const std::string& spec, int width, int height) {
  if (spec.empty()) throw Error("--projector: no screen given (e.g. :0.1 or HDMI-1)");
  std::unique_ptr<Projector> p(new Projector());
  p->spec_ = spec;
  InitVideo(IsX11Display(spec) ? spec : "");
  p->impl_ = std::make_unique<Impl>();  // from here on, the destructor quits SDL's video
  const auto screens = Screens(IsX11Display(spec) ? spec : "");
  const ScreenInfo* chosen = nullptr;
  if (IsX11Display(spec)) {
    if (!screens.empty()) chosen = &screens[0];
  } else {
    for (const auto& s : screens) {
      if (s.name == spec || std::to_string(s.index) == spec) chosen = &s;
    }
  }
  if (!chosen) {
    std::string names;
    for (const auto& s : screens)
      names += StrCat(names.empty() ? "" : ", ", s.index, " '", s.name, "'");
    throw Error(StrCat("projector screen '", spec,
                       "': no such screen (screens: ", names.empty() ? "none" : names, ")"));
  }
  p->screen_ = *chosen;
  if (chosen->width != width || chosen->height != height) {
    throw Error(StrCat("projector screen '", spec, "' is ", chosen->width, "x", chosen->height,
                       " px but the pattern scheme is ", width, "x", height,
                       " px: patterns are shown pixel for pixel, never scaled (give the scheme "
                       "the screen's size, e.g. --width ",
                       chosen->width, " --height ", chosen->height, ")"));
  }
  Impl& im = *p->impl_;
  im.window = SDL_CreateWindow("fringe projector", chosen->x, chosen->y, width, height,
                               SDL_WINDOW_BORDERLESS | SDL_WINDOW_SHOWN | SDL_WINDOW_ALWAYS_ON_TOP |
                                   SDL_WINDOW_SKIP_TASKBAR);
  if (!im.window) {
    throw Error(
        StrCat("projector screen '", spec, "': cannot create the window: ", SDL_GetError()));
  }
  SDL_ShowCursor(SDL_DISABLE);
  im.renderer = SDL_CreateRenderer(im.window, -1, SDL_RENDERER_PRESENTVSYNC);
  if (!im.renderer) {
    throw Error(
        StrCat("projector screen '", spec, "': cannot create a renderer: ", SDL_GetError()));
  }
  SDL_RendererInfo info;
  if (SDL_GetRendererInfo(im.renderer, &info) == 0 && info.name) p->renderer_name_ = info.name;
  im.texture = SDL_CreateTexture(im.renderer, SDL_PIXELFORMAT_ARGB8888, SDL_TEXTUREACCESS_STREAMING,
                                 width, height);
  if (!im.texture) {
    throw Error(StrCat("projector screen '", spec, "': cannot create a ", width, "x", height,
                       " texture: ", SDL_GetError()));
  }
  SDL_SetTextureBlendMode(im.texture, SDL_BLENDMODE_NONE);
  int w = 0, h = 0;
  SDL_GetWindowSize(im.window, &w, &h);
  if (w != width || h != height) {
    throw Error(StrCat("projector screen '", spec, "': the window manager made the window ", w, "x",
                       h, " instead of ", width, "x", height));
  }
  // The window is mapped asynchronously: wait until the window system exposed it, so that the
  // first pattern is not drawn into an unmapped window (at most 2 s; a window system that sends
  // no expose event still gets the window).
  const auto deadline = Clock::now() + std::chrono::seconds(2);
  for (bool exposed = false; !exposed && Clock::now() < deadline;) {
    SDL_Event event;
    while (SDL_PollEvent(&event)) {
      if (event.type == SDL_WINDOWEVENT && event.window.event == SDL_WINDOWEVENT_EXPOSED) {
        exposed = true;
      }
    }
    if (!exposed) SDL_Delay(5);
  }
  p->ShowLevel(0);
  return p;
}

Projector::~Projector() = default;

Projector::Clock::time_point Projector::Show(const cv::Mat& image) {
  if (image.type() != CV_8UC1 || image.cols != screen_.width || image.rows != screen_.height) {
    throw Error(StrCat("projector screen '", spec_, "': pattern must be an 8-bit ", screen_.width,
                       "x", screen_.height, " image, got ", image.cols, "x", image.rows,
                       " of type ", image.type()));
  }
  Impl& im = *impl_;
  // ARGB8888 is B, G, R, A in memory on a little-endian machine: grey to BGRA keeps the value
  // in every colour channel, no conversion of levels.
  cv::cvtColor(image, im.bgra, cv::COLOR_GRAY2BGRA);
  if (SDL_UpdateTexture(im.texture, nullptr, im.bgra.data, static_cast<int>(im.bgra.step)) != 0) {
    throw Error(
        StrCat("projector screen '", spec_, "': cannot upload the pattern: ", SDL_GetError()));
  }
  SDL_RenderClear(im.renderer);
  SDL_RenderCopy(im.renderer, im.texture, nullptr, nullptr);
  SDL_RenderPresent(im.renderer);
  SDL_PumpEvents();  // keeps the window responsive to the window system
  return Clock::now();
}

Projector::Clock::time_point Projector::ShowLevel(int level) {
  return Show(cv::Mat(screen_.height, screen_.width, CV_8UC1, cv::Scalar(level)));
}

}  // namespace fringe::capture
