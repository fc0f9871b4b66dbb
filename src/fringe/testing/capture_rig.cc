#include "fringe/testing/capture_rig.h"

#include <X11/Xlib.h>
#include <X11/Xutil.h>
#include <arv.h>
#include <ifaddrs.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace fringe::capture::test {

void EnterPrivateNetworkNamespace() {
  static bool entered = false;
  if (entered) return;
  const char* v = std::getenv("FRINGE_NETNS");
  if (!(v && std::string(v) == "1")) {
    // GigE Vision discovery broadcasts on every interface: no test packet may leave loopback.
    if (unshare(CLONE_NEWNET) != 0) {
      throw std::runtime_error(std::string("unshare(CLONE_NEWNET) failed (capture tests need "
                                           "root to get a private network namespace): ") +
                               std::strerror(errno));
    }
    const int rc = std::system(
        "ip link set lo up && ip addr add 127.0.0.2/8 dev lo && ip addr add 127.0.0.3/8 dev lo "
        "&& ip addr add 127.0.0.4/8 dev lo");
    if (rc != 0) throw std::runtime_error("setting up loopback in the namespace failed (ip)");
    setenv("FRINGE_NETNS", "1", 1);
  }
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) throw std::runtime_error("getifaddrs failed");
  std::string others;
  for (ifaddrs* i = list; i; i = i->ifa_next) {
    if (std::string(i->ifa_name) != "lo") others += std::string(" ") + i->ifa_name;
  }
  freeifaddrs(list);
  if (!others.empty()) {
    throw std::runtime_error("the network namespace has interfaces other than lo:" + others);
  }
  entered = true;
}

Xvfb::Xvfb(int width, int height) {
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error("Xvfb: pipe failed");
  pid_ = fork();
  if (pid_ < 0) throw std::runtime_error("Xvfb: fork failed");
  if (pid_ == 0) {
    close(fds[0]);
    const std::string fd = std::to_string(fds[1]);
    const std::string screen = std::to_string(width) + "x" + std::to_string(height) + "x24";
    execlp("Xvfb", "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", screen.c_str(), "-nolisten",
           "tcp", "-noreset", "-nocursor", static_cast<char*>(nullptr));
    _exit(127);
  }
  close(fds[1]);
  std::string number;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{fds[0], POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    char c;
    const ssize_t n = read(fds[0], &c, 1);
    if (n <= 0) break;  // Xvfb exited
    if (c == '\n') break;
    number += c;
  }
  close(fds[0]);
  if (number.empty()) {
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
    throw std::runtime_error("Xvfb did not start within 10 s (is the xvfb package installed?)");
  }
  display_ = ":" + number;
}

Xvfb::~Xvfb() {
  if (pid_ > 0) {
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
  }
}

ScreenReader::ScreenReader(const std::string& display) {
  display_ = XOpenDisplay(display.c_str());
  if (!display_) throw std::runtime_error("cannot open X display " + display);
}

ScreenReader::~ScreenReader() {
  if (display_) XCloseDisplay(static_cast<Display*>(display_));
}

cv::Mat ScreenReader::Read() {
  Display* d = static_cast<Display*>(display_);
  const Window root = DefaultRootWindow(d);
  XWindowAttributes a;
  XGetWindowAttributes(d, root, &a);
  XImage* image = XGetImage(d, root, 0, 0, a.width, a.height, AllPlanes, ZPixmap);
  if (!image) throw std::runtime_error("XGetImage failed");
  cv::Mat grey(a.height, a.width, CV_8UC1);
  if (image->bits_per_pixel == 32 && image->green_mask == 0xff00 && image->byte_order == LSBFirst) {
    // The usual TrueColor layout (B, G, R, X bytes): the green byte, row by row.
    for (int y = 0; y < a.height; ++y) {
      const auto* row = reinterpret_cast<const uint8_t*>(image->data + y * image->bytes_per_line);
      uint8_t* out = grey.ptr<uint8_t>(y);
      for (int x = 0; x < a.width; ++x) out[x] = row[4 * x + 1];
    }
  } else {
    for (int y = 0; y < a.height; ++y) {
      for (int x = 0; x < a.width; ++x) {
        grey.at<uint8_t>(y, x) =
            static_cast<uint8_t>((XGetPixel(image, x, y) & image->green_mask) >> 8);
      }
    }
  }
  XDestroyImage(image);
  return grey;
}

FakeCamera::FakeCamera(const std::string& address, const std::string& serial,
                       const std::string& display, Render render)
    : serial_(serial), display_(display), render_(std::move(render)) {
  ArvGvFakeCamera* c = arv_gv_fake_camera_new(address.c_str(), serial.c_str());
  if (!c || !arv_gv_fake_camera_is_running(c)) {
    if (c) g_object_unref(c);
    throw std::runtime_error("fake GigE Vision camera " + serial + " did not start on " + address +
                             " (is the address on lo? EnterPrivateNetworkNamespace adds it)");
  }
  camera_ = c;
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(c);
  // In trigger mode the fake camera polls for a trigger at this rate: fast enough not to be the
  // bottleneck of the tests.
  arv_fake_camera_set_trigger_frequency(fake, 500.0);
  arv_fake_camera_set_fill_pattern(
      fake, reinterpret_cast<ArvFakeCameraFillPattern>(&FakeCamera::Fill), this);
}

FakeCamera::~FakeCamera() {
  Kill();
  stop_sampler_ = true;
  if (sampler_.joinable()) sampler_.join();
}

void FakeCamera::SetInjectedLatency(double ms) {
  latency_ms_ = ms;
  if (ms <= 0 || sampler_.joinable()) return;
  sampler_ = std::thread([this] {
    Display* d = XOpenDisplay(display_.c_str());
    if (!d) return;
    const Window root = DefaultRootWindow(d);
    XWindowAttributes a;
    XGetWindowAttributes(d, root, &a);
    auto previous_request = std::chrono::steady_clock::now();
    while (!stop_sampler_) {
      const auto request = std::chrono::steady_clock::now();
      XImage* image = XGetImage(d, root, a.width / 2, a.height / 2, 1, 1, AllPlanes, ZPixmap);
      if (image) {
        const int level = static_cast<int>((XGetPixel(image, 0, 0) & image->green_mask) >> 8);
        XDestroyImage(image);
        const auto reply = std::chrono::steady_clock::now();
        std::lock_guard<std::mutex> lock(history_mutex_);
        if (!history_.empty() && history_.back().second != level) {
          max_sample_span_ms_ =
              std::max(max_sample_span_ms_,
                       std::chrono::duration<double, std::milli>(reply - previous_request).count());
        }
        previous_request = request;
        history_.emplace_back(reply, level);
        while (history_.size() > 20000) history_.pop_front();  // 5 s at 4 kHz
      }
      std::this_thread::sleep_for(std::chrono::microseconds(250));
    }
    XCloseDisplay(d);
  });
}

double FakeCamera::MaxInjectedLatencyErrorMs() const {
  std::lock_guard<std::mutex> lock(history_mutex_);
  return max_sample_span_ms_;
}

int FakeCamera::LevelAt(std::chrono::steady_clock::time_point t) {
  std::lock_guard<std::mutex> lock(history_mutex_);
  int level = 0;
  for (const auto& [when, value] : history_) {
    if (when > t) break;
    level = value;
  }
  return level;
}

void FakeCamera::Kill() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (camera_) {
    g_object_unref(static_cast<ArvGvFakeCamera*>(camera_));
    camera_ = nullptr;
  }
}

void FakeCamera::SetLostPacketRatio(double ratio) {
  g_object_set(static_cast<ArvGvFakeCamera*>(camera_), "gvsp-lost-ratio", ratio, nullptr);
}

void FakeCamera::SetSize(int width, int height) {
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(static_cast<ArvGvFakeCamera*>(camera_));
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_WIDTH, width);
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_HEIGHT, height);
}

void FakeCamera::Fill(void* buffer_ptr, void* self_ptr, unsigned exposure_us, unsigned gain,
                      unsigned pixel_format) {
  auto* self = static_cast<FakeCamera*>(self_ptr);
  auto* buffer = static_cast<ArvBuffer*>(buffer_ptr);
  const int frame = self->frames_++;
  if (self->on_frame) self->on_frame(frame);
  if (self->latency_ms_ > 0) {
    const auto seen = std::chrono::steady_clock::now() -
                      std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                          std::chrono::duration<double, std::milli>(self->latency_ms_));
    const int width = arv_buffer_get_image_width(buffer);
    const int height = arv_buffer_get_image_height(buffer);
    void* data = const_cast<void*>(arv_buffer_get_data(buffer, nullptr));
    if (!data || width <= 0 || height <= 0) return;
    const cv::Mat screen(1, 1, CV_8UC1, cv::Scalar(self->LevelAt(seen)));
    const int depth = ARV_PIXEL_FORMAT_BIT_PER_PIXEL(pixel_format) > 8 ? 16 : 8;
    cv::Mat out(height, width, depth == 16 ? CV_16UC1 : CV_8UC1, data);
    ResampleProjector(screen, width, height, depth, false).copyTo(out);
    return;
  }
  if (!self->reader_) self->reader_ = std::make_unique<ScreenReader>(self->display_);
  const int width = arv_buffer_get_image_width(buffer);
  const int height = arv_buffer_get_image_height(buffer);
  const int bits = ARV_PIXEL_FORMAT_BIT_PER_PIXEL(pixel_format);
  const int depth = bits > 8 ? 16 : 8;
  // The fake camera checked that the buffer holds the payload (width x height x pixel size)
  // before calling; the part's size is only set after this callback returns.
  void* data = const_cast<void*>(arv_buffer_get_data(buffer, nullptr));
  if (!data || width <= 0 || height <= 0) return;
  const cv::Mat image =
      self->render_(self->reader_->Read(), exposure_us, gain, width, height, depth);
  cv::Mat out(height, width, depth == 16 ? CV_16UC1 : CV_8UC1, data);
  image.copyTo(out);
}

cv::Mat ResampleProjector(const cv::Mat& projector, int width, int height, int bit_depth,
                          bool mirror) {
  cv::Mat out(height, width, bit_depth > 8 ? CV_16UC1 : CV_8UC1);
  std::vector<int> columns(width);
  for (int x = 0; x < width; ++x) {
    const int px =
        std::min(projector.cols - 1, static_cast<int>((x + 0.5) * projector.cols / width));
    columns[x] = mirror ? projector.cols - 1 - px : px;
  }
  for (int y = 0; y < height; ++y) {
    const int py =
        std::min(projector.rows - 1, static_cast<int>((y + 0.5) * projector.rows / height));
    const uint8_t* in = projector.ptr<uint8_t>(py);
    for (int x = 0; x < width; ++x) {
      // A camera that sees the projector's full range without saturating.
      const int v = 16 + 3 * in[columns[x]] / 4;
      if (bit_depth > 8) {
        out.ptr<uint16_t>(y)[x] = static_cast<uint16_t>((v * 257) >> (16 - bit_depth));
      } else {
        out.ptr<uint8_t>(y)[x] = static_cast<uint8_t>(v);
      }
    }
  }
  return out;
}

}  // namespace fringe::capture::test
