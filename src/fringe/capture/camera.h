// Cameras for capture: one small interface over the backends a fringe sensor uses — GenICam
// cameras (GigE Vision, USB3 Vision) through Aravis and UVC webcams through OpenCV's
// VideoCapture (V4L2). The sequencer (capture.h) drives every camera through this interface
// only, so adding a backend is one class (docs/capture.md, "Adding a backend").
//
// Thread safety: one Camera is used from one thread at a time.
#pragma once

#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace fringe::capture {

// What a backend knows about a camera (`fringe devices`, the capture settings of a scan).
struct CameraInfo {
  std::string backend;  // "aravis" | "opencv"
  std::string id;       // the id that opens it again (Aravis device id, "opencv:N")
  std::string vendor;   // empty when the backend does not say
  std::string model;
  std::string serial;
  std::string interface;      // "GigEVision 127.0.0.2", "USB3Vision", "V4L2 /dev/video0"
  std::string pixel_format;   // current format, e.g. "Mono8", "Mono12"
  int width = 0, height = 0;  // current image size, px
};
nlohmann::json ToJson(const CameraInfo& info);

// How a frame's exposure starts.
enum class TriggerSource {
  kSoftware,  // Camera::Trigger() (TriggerMode=On, TriggerSource=Software)
  kLine1,     // a hardware trigger on input line 1, e.g. from the projector's sync output
  kFreeRun,   // no trigger (webcams): the camera streams, the sequencer drains stale frames
};
const char* TriggerSourceName(TriggerSource source);  // "software" | "line1" | "free-run"
// "software", "line1" (also "line0", "line2", ... as the GenICam line names) or "free-run";
// throws fringe::Error naming the flag otherwise.
TriggerSource ParseTriggerSource(const std::string& name);

struct CameraSettings {
  double exposure_us = 10000;  // exposure time, microseconds (> 0)
  double gain = 0;             // analog gain in the camera's unit (dB for GenICam), >= 0
  // Pixel format: "Mono8", "Mono10", "Mono12", "Mono14", "Mono16" (unpacked; 16-bit PNG out);
  // empty keeps the camera's current format.
  std::string pixel_format = "Mono8";
  // Region of interest, px; width/height 0 keep the camera's current region.
  int roi_x = 0, roi_y = 0, roi_width = 0, roi_height = 0;
  TriggerSource trigger = TriggerSource::kSoftware;
  // The hardware trigger's GenICam line name ("Line1"), used when trigger == kLine1.
  std::string trigger_line = "Line1";
  // GigE Vision: ask the camera to resend lost packets (the stream's default). Off, a frame
  // with a lost packet is incomplete and the sequencer shows the pattern again.
  bool packet_resend = true;
  void Check() const;  // throws fringe::Error naming the field
};

// One grabbed image with what the device said about it.
struct Frame {
  cv::Mat image;                     // CV_8UC1, or CV_16UC1 holding `bit_depth`-bit values
  int bit_depth = 8;                 // significant bits per pixel: 8, 10, 12, 14 or 16
  uint64_t frame_id = 0;             // the device's frame counter (GigE Vision: 16 bit, 0 invalid)
  uint64_t timestamp_ns = 0;         // device timestamp, ns (0 when the device gives none)
  uint64_t system_timestamp_ns = 0;  // host time the frame arrived, ns (steady clock)
};

struct StreamStatistics {
  uint64_t completed = 0;        // frames received complete
  uint64_t failed = 0;           // frames incomplete or timed out in the stream
  uint64_t resent_packets = 0;   // GigE Vision: packets lost and recovered by a resend request
  uint64_t missing_packets = 0;  // GigE Vision: packets lost for good (their frame failed)
};

// Why a grab failed; the sequencer retries kIncomplete and kTimeout (re-showing the pattern)
// and stops at kLost.
enum class GrabStatus {
  kOk,
  kTimeout,     // no frame within the timeout
  kIncomplete,  // a frame came but with missing packets or another stream error
  kLost,        // the device is gone (control connection lost, unplugged)
};

struct GrabResult {
  GrabStatus status = GrabStatus::kOk;
  std::string message;  // what went wrong, naming the camera (empty when kOk)
  Frame frame;
};

class Camera {
 public:
  virtual ~Camera() = default;
  virtual CameraInfo Info() const = 0;
  // Applies the settings (before Start()); throws fringe::Error naming the camera and the
  // setting the device refused.
  virtual void Configure(const CameraSettings& settings) = 0;
  // Starts acquisition: buffers sized for the configured frame are queued.
  virtual void Start() = 0;
  // Drops every frame already received (a triggered camera has none; a streaming webcam does).
  virtual void Drain() = 0;
  // Starts one exposure (software trigger). No-op for hardware-triggered and free-running
  // cameras. Throws fringe::Error when the device refuses the command.
  virtual void Trigger() = 0;
  // Waits up to timeout_ms for the next frame.
  virtual GrabResult Grab(int timeout_ms) = 0;
  virtual void Stop() = 0;
  // Stream statistics since Start().
  virtual StreamStatistics Statistics() const = 0;
  // The exposure times the device accepts, us; false when it does not say (webcams: V4L2's
  // exposure is a driver-defined unit), and --auto-exposure cannot search it.
  virtual bool ExposureRangeUs(double* min_us, double* max_us) const {
    (void)min_us;
    (void)max_us;
    return false;
  }
};

// Opens a camera by a user's spec:
//   "aravis:ID" or a plain ID — an Aravis camera by device id, serial number or IP address;
//   "opencv:N", "/dev/videoN" — an OpenCV VideoCapture device (V4L2).
// Throws fringe::Error naming the spec when no such camera exists or it cannot be opened.
std::unique_ptr<Camera> OpenCamera(const std::string& spec);

// Every camera the backends find. Aravis discovery broadcasts on every network interface
// (GigE Vision); `probe_opencv` also opens /dev/video0..9 to read their sizes.
std::vector<CameraInfo> ListCameras(bool probe_opencv = true);

}  // namespace fringe::capture
