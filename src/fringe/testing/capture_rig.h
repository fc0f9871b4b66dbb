// Test fixtures of the capture tests: an Xvfb server as the projector's screen and Aravis'
// in-process fake GigE Vision cameras (ArvGvFakeCamera) on loopback addresses, whose images are
// rendered from what the projector window shows right now (read back from the X server with
// XGetImage, never passed around the capture code). The tests run inside a private network
// namespace holding only loopback; a fixture that cannot start fails the test.
#pragma once

#include <atomic>
#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <thread>

namespace fringe::capture::test {

// Moves this process into a fresh network namespace holding only loopback, with the
// addresses the fake cameras bind to (127.0.0.2 .. 127.0.0.4), unless the caller set one up
// (FRINGE_NETNS=1, e.g. after `unshare -n` and `ip addr add`). Needs root (CAP_SYS_ADMIN).
// Then checks that loopback is the only interface. Call before any thread starts (the first
// fixture does); throws std::runtime_error saying what failed.
void EnterPrivateNetworkNamespace();

// An Xvfb server with one screen of width x height x 24 bit; the display number is chosen by
// Xvfb (-displayfd), so tests can run in parallel. Throws std::runtime_error when it does not
// start within 10 s.
class Xvfb {
 public:
  Xvfb(int width, int height);
  ~Xvfb();
  const std::string& display() const { return display_; }  // ":N"

 private:
  int pid_ = -1;
  std::string display_;
};

// Reads the X server's screen (the root window) as an 8-bit grey image (the green channel;
// the projector shows grey). One connection per object; not thread safe (one per thread).
class ScreenReader {
 public:
  explicit ScreenReader(const std::string& display);
  ~ScreenReader();
  cv::Mat Read();

 private:
  void* display_ = nullptr;  // Display*
};

// Renders a camera image from the projector image that is on the screen when the frame is
// made: (screen image, exposure us, gain) -> camera image (CV_8UC1 or CV_16UC1 of the
// camera's size and depth).
using Render = std::function<cv::Mat(const cv::Mat& screen, double exposure_us, double gain,
                                     int width, int height, int bit_depth)>;

// One ArvGvFakeCamera bound to `address` (a loopback address EnterPrivateNetworkNamespace adds).
class FakeCamera {
 public:
  FakeCamera(const std::string& address, const std::string& serial, const std::string& display,
             Render render);
  ~FakeCamera();
  // GVSP packet loss, a ratio in [0, 1) (Aravis' gvsp-lost-ratio).
  void SetLostPacketRatio(double ratio);
  // Sets the image size through the device registers (the default is 512 x 512).
  void SetSize(int width, int height);
  // A projector that shows a frame `ms` after it was presented: a thread samples the centre
  // pixel of the screen every 0.25 ms, and every frame is the uniform level the screen had
  // `ms` before the frame is made (through the same response as ResampleProjector). 0: off.
  void SetInjectedLatency(double ms);
  // How late the injected latency can be on top of `ms`: a sample is stamped when its reply
  // arrives, so a change of the screen enters the history up to one sample's span (from the
  // request of the sample before to the reply of the one that saw the change) late. The largest
  // such span over the changes seen so far, ms: the sampler's sleep plus two X round trips,
  // longer when the X server is busy or the machine loaded.
  double MaxInjectedLatencyErrorMs() const;
  // Stops the device (as if unplugged): its control and stream channels go silent.
  void Kill();
  int frames() const { return frames_; }
  const std::string& serial() const { return serial_; }
  // Called from the fake camera's thread before every frame (e.g. to kill another camera).
  std::function<void(int frame)> on_frame;

 private:
  static void Fill(void* buffer, void* self, unsigned exposure_us, unsigned gain,
                   unsigned pixel_format);
  void* camera_ = nullptr;  // ArvGvFakeCamera*
  std::string serial_, display_;
  Render render_;
  std::unique_ptr<ScreenReader> reader_;  // created in the fake camera's thread
  std::atomic<int> frames_{0};
  std::mutex mutex_;
  // Injected latency: the screen's centre level over time.
  double latency_ms_ = 0;
  std::thread sampler_;
  std::atomic<bool> stop_sampler_{false};
  mutable std::mutex history_mutex_;
  std::deque<std::pair<std::chrono::steady_clock::time_point, int>> history_;
  double max_sample_span_ms_ = 0;  // under history_mutex_
  int LevelAt(std::chrono::steady_clock::time_point t);
};

// The projector-to-camera mapping of the simple tests: camera pixel (x, y) sees projector pixel
// (floor((x + 0.5) * pw / w), floor((y + 0.5) * ph / h)), mirrored in x when `mirror` (the
// right camera), with the response 16 + 3 v / 4 (no saturation), scaled to the bit depth
// (value * 257 >> (16 - bit_depth) for 16-bit formats).
cv::Mat ResampleProjector(const cv::Mat& projector, int width, int height, int bit_depth,
                          bool mirror);

}  // namespace fringe::capture::test
