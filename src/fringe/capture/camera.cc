#include "fringe/capture/camera.h"

#include <cctype>

#include "fringe/capture/aravis_camera.h"
#include "fringe/capture/opencv_camera.h"
#include "fringe/util/error.h"

namespace fringe::capture {

using util::StrCat;

nlohmann::json ToJson(const CameraInfo& i) {
  return {{"backend", i.backend},
          {"id", i.id},
          {"vendor", i.vendor},
          {"model", i.model},
          {"serial", i.serial},
          {"interface", i.interface},
          {"pixel_format", i.pixel_format},
          {"width", i.width},
          {"height", i.height}};
}

const char* TriggerSourceName(TriggerSource source) {
  switch (source) {
    case TriggerSource::kSoftware:
      return "software";
    case TriggerSource::kLine1:
      return "line1";
    case TriggerSource::kFreeRun:
      return "free-run";
  }
  return "?";
}

TriggerSource ParseTriggerSource(const std::string& name) {
  if (name == "software") return TriggerSource::kSoftware;
  if (name == "free-run") return TriggerSource::kFreeRun;
  if (name.size() == 5 && name.compare(0, 4, "line") == 0 && std::isdigit(name[4])) {
    return TriggerSource::kLine1;
  }
  throw Error(StrCat("--trigger '", name,
                     "': expected software, line1 (or line0, line2, ...) "
                     "or free-run"));
}

void CameraSettings::Check() const {
  util::CheckOption(exposure_us > 0 && exposure_us <= 1e8, "CameraSettings", "exposure_us",
                    exposure_us, "must be in (0, 1e8] us");
  util::CheckOption(gain >= 0 && gain <= 1000, "CameraSettings", "gain", gain,
                    "must be in [0, 1000]");
  util::CheckOption(roi_x >= 0 && roi_y >= 0 && roi_width >= 0 && roi_height >= 0, "CameraSettings",
                    "roi", StrCat(roi_x, ",", roi_y, ",", roi_width, ",", roi_height),
                    "offsets and sizes must be >= 0");
  util::CheckOption(trigger != TriggerSource::kLine1 || !trigger_line.empty(), "CameraSettings",
                    "trigger_line", trigger_line, "must name the GenICam input line");
}

std::unique_ptr<Camera> OpenCamera(const std::string& spec) {
  if (spec.rfind("opencv:", 0) == 0 || spec.rfind("/dev/video", 0) == 0) {
    const std::string number = spec.substr(spec[0] == '/' ? 10 : 7);
    if (number.empty() || number.size() > 3 ||
        number.find_first_not_of("0123456789") != std::string::npos) {
      throw Error(StrCat("camera '", spec, "': expected opencv:N or /dev/videoN"));
    }
    return OpenOpenCvCamera(std::stoi(number));
  }
  if (spec.rfind("aravis:", 0) == 0) return OpenAravisCamera(spec.substr(7));
  return OpenAravisCamera(spec);
}

std::vector<CameraInfo> ListCameras(bool probe_opencv) {
  std::vector<CameraInfo> cameras = ListAravisCameras();
  if (probe_opencv) {
    for (auto& c : ListOpenCvCameras()) cameras.push_back(std::move(c));
  }
  return cameras;
}

}  // namespace fringe::capture
