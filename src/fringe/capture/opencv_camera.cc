#include "fringe/capture/opencv_camera.h"

#include <chrono>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "fringe/util/error.h"

namespace fringe::capture {
namespace {

using util::StrCat;
using Clock = std::chrono::steady_clock;

// A webcam streams on its own: there is no trigger, and V4L2 queues a few frames (usually 4)
// that were exposed before the pattern changed. Drain() reads frames until one had to be
// waited for (the queue is then empty, so the next frame starts exposing after the call), at
// most kMaxDrainFrames.
constexpr int kMaxDrainFrames = 10;

class OpenCvCamera final : public Camera {
 public:
  explicit OpenCvCamera(int index) : index_(index) {
    if (!capture_.open(index, cv::CAP_V4L2)) {
      throw Error(StrCat("camera opencv:", index, ": cannot open /dev/video", index,
                         " with OpenCV VideoCapture (V4L2)"));
    }
    capture_.set(cv::CAP_PROP_BUFFERSIZE, 1);
  }

  CameraInfo Info() const override {
    CameraInfo i;
    i.backend = "opencv";
    i.id = StrCat("opencv:", index_);
    i.model = capture_.getBackendName();
    i.interface = StrCat("V4L2 /dev/video", index_);
    i.pixel_format = "Mono8 (converted from the device format)";
    i.width = static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_WIDTH));
    i.height = static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_HEIGHT));
    return i;
  }

  void Configure(const CameraSettings& s) override {
    s.Check();
    if (s.trigger == TriggerSource::kLine1) {
      throw Error(StrCat("camera opencv:", index_, ": a webcam has no hardware trigger input"));
    }
    if (!s.pixel_format.empty() && s.pixel_format != "Mono8") {
      throw Error(StrCat("camera opencv:", index_, ": pixel format '", s.pixel_format,
                         "' not available (webcams give 8-bit images: Mono8)"));
    }
    if (s.roi_width > 0 && s.roi_height > 0) {
      capture_.set(cv::CAP_PROP_FRAME_WIDTH, s.roi_width);
      capture_.set(cv::CAP_PROP_FRAME_HEIGHT, s.roi_height);
    }
    // V4L2: manual exposure is auto-exposure mode 1, exposure in units of 100 us.
    capture_.set(cv::CAP_PROP_AUTO_EXPOSURE, 1);
    if (!capture_.set(cv::CAP_PROP_EXPOSURE, s.exposure_us / 100.0)) {
      throw Error(
          StrCat("camera opencv:", index_, ": the device refused exposure ", s.exposure_us, " us"));
    }
    if (s.gain > 0) capture_.set(cv::CAP_PROP_GAIN, s.gain);
  }

  void Start() override {}

  void Drain() override {
    for (int k = 0; k < kMaxDrainFrames; ++k) {
      const auto t0 = Clock::now();
      if (!capture_.grab()) return;
      const double waited_s = std::chrono::duration<double>(Clock::now() - t0).count();
      const double fps = capture_.get(cv::CAP_PROP_FPS);
      if (fps > 0 && waited_s > 0.5 / fps) return;  // a fresh frame: the queue is empty
    }
  }

  void Trigger() override {}

  GrabResult Grab(int timeout_ms) override {
    GrabResult r;
    const auto t0 = Clock::now();
    cv::Mat image;
    if (!capture_.read(image) || image.empty()) {
      const double waited_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      r.status = waited_ms >= timeout_ms ? GrabStatus::kTimeout : GrabStatus::kLost;
      r.message = StrCat("camera opencv:", index_, ": no frame (device gone or stopped)");
      ++failed_;
      return r;
    }
    if (image.channels() == 3) {
      cv::cvtColor(image, r.frame.image, cv::COLOR_BGR2GRAY);
    } else if (image.channels() == 4) {
      cv::cvtColor(image, r.frame.image, cv::COLOR_BGRA2GRAY);
    } else {
      r.frame.image = image;
    }
    r.frame.bit_depth = 8;
    r.frame.frame_id = ++frames_;
    r.frame.timestamp_ns = static_cast<uint64_t>(capture_.get(cv::CAP_PROP_POS_MSEC) * 1e6);
    r.frame.system_timestamp_ns =
        static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                  std::chrono::system_clock::now().time_since_epoch())
                                  .count());
    return r;
  }

  void Stop() override {}
  StreamStatistics Statistics() const override {
    StreamStatistics s;
    s.completed = frames_;
    s.failed = failed_;
    return s;
  }

 private:
  int index_;
  mutable cv::VideoCapture capture_;
  uint64_t frames_ = 0, failed_ = 0;
};

}  // namespace

std::unique_ptr<Camera> OpenOpenCvCamera(int index) {
  util::CheckRange(index, 0, 255, "opencv camera", "index");
  return std::make_unique<OpenCvCamera>(index);
}

std::vector<CameraInfo> ListOpenCvCameras(int max_index) {
  std::vector<CameraInfo> cameras;
  for (int k = 0; k <= max_index; ++k) {
    std::error_code ec;
    if (!std::filesystem::exists(StrCat("/dev/video", k), ec)) continue;
    try {
      cameras.push_back(OpenOpenCvCamera(k)->Info());
    } catch (const Error&) {
      // A V4L2 node that is not a capture device (metadata nodes of UVC cameras): not listed.
    }
  }
  return cameras;
}

}  // namespace fringe::capture
