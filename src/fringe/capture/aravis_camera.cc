#include "fringe/capture/aravis_camera.h"

#include <arv.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <opencv2/core.hpp>

#include "fringe/util/error.h"

namespace fringe::capture {
namespace {

using util::StrCat;

// Buffers queued on the stream: one frame is in flight per trigger, the others absorb a late
// frame of a retried pattern without an underrun.
constexpr int kStreamBuffers = 4;

std::string TakeError(GError** error) {
  std::string message = (error && *error) ? (*error)->message : "unknown error";
  if (error) g_clear_error(error);
  return message;
}

std::string GetString(const char* s) { return s ? s : ""; }

class AravisCamera final : public Camera {
 public:
  AravisCamera(ArvCamera* camera, std::string id, std::string spec)
      : camera_(camera), id_(std::move(id)), spec_(std::move(spec)) {
    // The device reports a lost control channel (heartbeat failed: unplugged, powered off,
    // another host took it) with a signal from Aravis' own thread.
    ArvDevice* device = arv_camera_get_device(camera_);
    g_signal_connect(device, "control-lost", G_CALLBACK(&AravisCamera::OnControlLost), this);
    info_ = ReadInfo();
  }
  ~AravisCamera() override {
    Stop();
    g_signal_handlers_disconnect_by_data(arv_camera_get_device(camera_), this);
    g_object_unref(camera_);
  }

  CameraInfo Info() const override { return info_; }

  void Configure(const CameraSettings& s) override {
    s.Check();
    GError* error = nullptr;
    auto require = [&](const char* what) {
      if (error) {
        throw Error(StrCat("camera ", Name(), ": cannot set ", what, ": ", TakeError(&error)));
      }
    };
    if (!s.pixel_format.empty()) {
      if (MonoBitDepth(s.pixel_format) == 0) {
        throw Error(StrCat("camera ", Name(), ": pixel format '", s.pixel_format,
                           "' is not supported (Mono8, Mono10, Mono12, Mono14, Mono16)"));
      }
      arv_camera_set_pixel_format_from_string(camera_, s.pixel_format.c_str(), &error);
      require(StrCat("pixel format ", s.pixel_format).c_str());
    }
    const std::string format = GetString(arv_camera_get_pixel_format_as_string(camera_, &error));
    require("pixel format (read back)");
    bit_depth_ = MonoBitDepth(format);
    if (bit_depth_ == 0) {
      throw Error(StrCat("camera ", Name(), ": current pixel format '", format,
                         "' is not supported; choose Mono8, Mono10, Mono12, Mono14 or Mono16"));
    }
    if (s.roi_width > 0 && s.roi_height > 0) {
      arv_camera_set_region(camera_, s.roi_x, s.roi_y, s.roi_width, s.roi_height, &error);
      require("region of interest");
    }
    if (arv_camera_is_exposure_time_available(camera_, nullptr)) {
      double lo = 0, hi = 0;
      arv_camera_get_exposure_time_bounds(camera_, &lo, &hi, &error);
      require("exposure time (bounds)");
      if (s.exposure_us < lo || s.exposure_us > hi) {
        throw Error(StrCat("camera ", Name(), ": exposure ", s.exposure_us,
                           " us is outside the camera's range [", lo, ", ", hi, "] us"));
      }
      arv_camera_set_exposure_time(camera_, s.exposure_us, &error);
      require("exposure time");
    }
    if (arv_camera_is_gain_available(camera_, nullptr)) {
      arv_camera_set_gain(camera_, s.gain, &error);
      require("gain");
    } else if (s.gain != 0) {
      throw Error(StrCat("camera ", Name(), ": has no gain setting (gain ", s.gain, " asked)"));
    }
    switch (s.trigger) {
      case TriggerSource::kSoftware:
        arv_camera_set_trigger(camera_, "Software", &error);
        break;
      case TriggerSource::kLine1:
        arv_camera_set_trigger(camera_, s.trigger_line.c_str(), &error);
        break;
      case TriggerSource::kFreeRun:
        arv_camera_clear_triggers(camera_, &error);
        break;
    }
    require(StrCat("trigger ", TriggerSourceName(s.trigger)).c_str());
    trigger_ = s.trigger;
    packet_resend_ = s.packet_resend;
    info_ = ReadInfo();
  }

  bool ExposureRangeUs(double* min_us, double* max_us) const override {
    if (!arv_camera_is_exposure_time_available(camera_, nullptr)) return false;
    GError* error = nullptr;
    arv_camera_get_exposure_time_bounds(camera_, min_us, max_us, &error);
    if (error) {
      g_clear_error(&error);
      return false;
    }
    return *min_us > 0 && *max_us >= *min_us;
  }

  void Start() override {
    if (stream_) return;
    GError* error = nullptr;
    stream_ = arv_camera_create_stream(camera_, nullptr, nullptr, &error);
    if (!stream_) {
      throw Error(StrCat("camera ", Name(), ": cannot open the stream: ", TakeError(&error)));
    }
    const guint payload = arv_camera_get_payload(camera_, &error);
    if (error || payload == 0) {
      throw Error(StrCat("camera ", Name(), ": cannot read the payload size: ", TakeError(&error)));
    }
    if (ARV_IS_GV_STREAM(stream_)) {
      g_object_set(
          stream_, "packet-resend",
          packet_resend_ ? ARV_GV_STREAM_PACKET_RESEND_ALWAYS : ARV_GV_STREAM_PACKET_RESEND_NEVER,
          nullptr);
    }
    for (int i = 0; i < kStreamBuffers; ++i) {
      arv_stream_push_buffer(stream_, arv_buffer_new(payload, nullptr));
    }
    arv_camera_set_acquisition_mode(camera_, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
    if (error) {
      throw Error(
          StrCat("camera ", Name(), ": cannot set continuous acquisition: ", TakeError(&error)));
    }
    arv_camera_start_acquisition(camera_, &error);
    if (error) {
      throw Error(StrCat("camera ", Name(), ": cannot start acquisition: ", TakeError(&error)));
    }
    StatsAtStart();
  }

  void Drain() override {
    if (!stream_) return;
    while (ArvBuffer* b = arv_stream_try_pop_buffer(stream_)) arv_stream_push_buffer(stream_, b);
  }

  void Trigger() override {
    if (trigger_ != TriggerSource::kSoftware) return;
    if (lost_) throw Error(StrCat("camera ", Name(), ": control connection lost"));
    GError* error = nullptr;
    arv_camera_software_trigger(camera_, &error);
    if (error) {
      throw Error(StrCat("camera ", Name(), ": software trigger failed: ", TakeError(&error)));
    }
  }

  GrabResult Grab(int timeout_ms) override {
    GrabResult r;
    if (!stream_) throw Error(StrCat("camera ", Name(), ": Grab() before Start()"));
    if (lost_) {
      r.status = GrabStatus::kLost;
      r.message = StrCat("camera ", Name(), ": control connection lost");
      return r;
    }
    ArvBuffer* b = arv_stream_timeout_pop_buffer(stream_, static_cast<guint64>(timeout_ms) * 1000);
    if (!b) {
      r.status = lost_ ? GrabStatus::kLost : GrabStatus::kTimeout;
      r.message = lost_ ? StrCat("camera ", Name(), ": control connection lost")
                        : StrCat("camera ", Name(), ": no frame within ", timeout_ms, " ms");
      return r;
    }
    const ArvBufferStatus status = arv_buffer_get_status(b);
    if (status != ARV_BUFFER_STATUS_SUCCESS) {
      r.status = GrabStatus::kIncomplete;
      r.message = StrCat("camera ", Name(), ": frame ", arv_buffer_get_frame_id(b), " incomplete (",
                         StatusName(status), ")");
      arv_stream_push_buffer(stream_, b);
      return r;
    }
    const int width = arv_buffer_get_image_width(b);
    const int height = arv_buffer_get_image_height(b);
    const ArvPixelFormat format = arv_buffer_get_image_pixel_format(b);
    const int bits = ARV_PIXEL_FORMAT_BIT_PER_PIXEL(format);
    size_t size = 0;
    const void* data = arv_buffer_get_image_data(b, &size);
    const size_t expected = static_cast<size_t>(width) * height * (bits > 8 ? 2 : 1);
    if (width <= 0 || height <= 0 || (bits != 8 && bits != 16) || size < expected || !data) {
      r.status = GrabStatus::kIncomplete;
      r.message = StrCat("camera ", Name(), ": frame ", arv_buffer_get_frame_id(b), " is ", width,
                         "x", height, " with ", bits, " bits per pixel and ", size,
                         " bytes, not a monochrome image");
      arv_stream_push_buffer(stream_, b);
      return r;
    }
    const cv::Mat view(height, width, bits > 8 ? CV_16UC1 : CV_8UC1, const_cast<void*>(data));
    r.frame.image = view.clone();
    r.frame.bit_depth = bits > 8 ? bit_depth_ : 8;
    r.frame.frame_id = arv_buffer_get_frame_id(b);
    r.frame.timestamp_ns = arv_buffer_get_timestamp(b);
    r.frame.system_timestamp_ns = arv_buffer_get_system_timestamp(b);
    arv_stream_push_buffer(stream_, b);
    return r;
  }

  void Stop() override {
    if (!stream_) return;
    if (!lost_) arv_camera_stop_acquisition(camera_, nullptr);
    g_object_unref(stream_);
    stream_ = nullptr;
  }

  StreamStatistics Statistics() const override {
    StreamStatistics s;
    const auto frames = Stats();
    s.completed = frames.first - completed_at_start_;
    s.failed = frames.second - failed_at_start_;
    if (stream_ && ARV_IS_GV_STREAM(stream_)) {
      guint64 resent = 0, missing = 0;
      arv_gv_stream_get_statistics(ARV_GV_STREAM(stream_), &resent, &missing);
      s.resent_packets = resent;
      s.missing_packets = missing;
    }
    return s;
  }

 private:
  static void OnControlLost(ArvDevice*, gpointer self) {
    static_cast<AravisCamera*>(self)->lost_ = true;
  }

  static const char* StatusName(ArvBufferStatus s) {
    switch (s) {
      case ARV_BUFFER_STATUS_MISSING_PACKETS:
        return "missing packets";
      case ARV_BUFFER_STATUS_WRONG_PACKET_ID:
        return "wrong packet id";
      case ARV_BUFFER_STATUS_SIZE_MISMATCH:
        return "size mismatch";
      case ARV_BUFFER_STATUS_FILLING:
        return "still filling";
      case ARV_BUFFER_STATUS_ABORTED:
        return "aborted";
      case ARV_BUFFER_STATUS_TIMEOUT:
        return "timeout";
      default:
        return "stream error";
    }
  }

  std::pair<uint64_t, uint64_t> Stats() const {
    if (!stream_) return {0, 0};
    guint64 completed = 0, failed = 0, underruns = 0;
    arv_stream_get_statistics(stream_, &completed, &failed, &underruns);
    return {completed, failed};
  }
  void StatsAtStart() {
    const auto s = Stats();
    completed_at_start_ = s.first;
    failed_at_start_ = s.second;
  }

  // The camera as the user named it, with the device id and serial when they differ.
  std::string Name() const {
    std::string extra;
    if (id_ != spec_) extra = id_;
    if (!info_.serial.empty() && info_.serial != spec_) {
      extra += StrCat(extra.empty() ? "" : ", ", "serial ", info_.serial);
    }
    return extra.empty() ? spec_ : StrCat(spec_, " (", extra, ")");
  }

  CameraInfo ReadInfo() const {
    CameraInfo i;
    i.backend = "aravis";
    ArvDevice* device = arv_camera_get_device(camera_);
    i.id = id_;
    i.vendor = GetString(arv_camera_get_vendor_name(camera_, nullptr));
    i.model = GetString(arv_camera_get_model_name(camera_, nullptr));
    i.serial = GetString(arv_camera_get_device_serial_number(camera_, nullptr));
    if (ARV_IS_GV_DEVICE(device)) {
      GSocketAddress* socket = arv_gv_device_get_device_address(ARV_GV_DEVICE(device));
      GInetAddress* address =
          socket ? g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(socket)) : nullptr;
      gchar* text = address ? g_inet_address_to_string(address) : nullptr;
      i.interface = StrCat("GigEVision ", text ? text : "");
      g_free(text);
    } else {
      i.interface = arv_camera_is_uv_device(camera_) ? "USB3Vision" : "GenICam";
    }
    i.pixel_format = GetString(arv_camera_get_pixel_format_as_string(camera_, nullptr));
    gint x = 0, y = 0, w = 0, h = 0;
    arv_camera_get_region(camera_, &x, &y, &w, &h, nullptr);
    i.width = w;
    i.height = h;
    return i;
  }

  ArvCamera* camera_ = nullptr;
  ArvStream* stream_ = nullptr;
  std::string id_;    // Aravis device id
  std::string spec_;  // what the user gave (id, serial or address)
  CameraInfo info_;
  TriggerSource trigger_ = TriggerSource::kFreeRun;
  int bit_depth_ = 8;
  bool packet_resend_ = true;
  std::atomic<bool> lost_{false};
  uint64_t completed_at_start_ = 0, failed_at_start_ = 0;
};

}  // namespace

int MonoBitDepth(const std::string& f) {
  if (f == "Mono8") return 8;
  if (f == "Mono10") return 10;
  if (f == "Mono12") return 12;
  if (f == "Mono14") return 14;
  if (f == "Mono16") return 16;
  return 0;
}

std::vector<CameraInfo> ListAravisCameras() {
  arv_update_device_list();
  std::vector<CameraInfo> cameras;
  const unsigned n = arv_get_n_devices();
  for (unsigned k = 0; k < n; ++k) {
    CameraInfo i;
    i.backend = "aravis";
    i.id = GetString(arv_get_device_id(k));
    i.vendor = GetString(arv_get_device_vendor(k));
    i.model = GetString(arv_get_device_model(k));
    i.serial = GetString(arv_get_device_serial_nbr(k));
    i.interface =
        StrCat(GetString(arv_get_device_protocol(k)), " ", GetString(arv_get_device_address(k)));
    // Format and size need the device opened; a camera another host holds is still listed.
    GError* error = nullptr;
    if (ArvCamera* c = arv_camera_new(i.id.c_str(), &error)) {
      i.pixel_format = GetString(arv_camera_get_pixel_format_as_string(c, nullptr));
      gint x = 0, y = 0, w = 0, h = 0;
      arv_camera_get_region(c, &x, &y, &w, &h, nullptr);
      i.width = w;
      i.height = h;
      g_object_unref(c);
    } else {
      g_clear_error(&error);
    }
    cameras.push_back(i);
  }
  return cameras;
}

std::unique_ptr<Camera> OpenAravisCamera(const std::string& id) {
  if (id.empty()) throw Error("camera id is empty");
  // A serial number or address that discovery lists maps to its device id; anything else is
  // given to Aravis as is (a device id, or an IP address opened by unicast).
  std::string device_id = id;
  arv_update_device_list();
  const unsigned n = arv_get_n_devices();
  for (unsigned k = 0; k < n; ++k) {
    if (GetString(arv_get_device_id(k)) == id || GetString(arv_get_device_serial_nbr(k)) == id ||
        GetString(arv_get_device_address(k)) == id) {
      device_id = GetString(arv_get_device_id(k));
      break;
    }
  }
  GError* error = nullptr;
  ArvCamera* camera = arv_camera_new(device_id.c_str(), &error);
  if (!camera) {
    throw Error(StrCat("camera '", id, "': cannot open it with Aravis: ", TakeError(&error),
                       " (`fringe devices` lists the cameras found)"));
  }
  return std::make_unique<AravisCamera>(camera, device_id, id);
}

}  // namespace fringe::capture
