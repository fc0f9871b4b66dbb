// The Aravis backend: GenICam cameras over GigE Vision and USB3 Vision (Debian libaravis-dev,
// API 0.8). Internal to the capture module; use OpenCamera("aravis:ID") (camera.h).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "fringe/capture/camera.h"

namespace fringe::capture {

// Opens the camera whose Aravis device id, serial number or address is `id` (an IP address
// that discovery did not list is opened by unicast). Throws fringe::Error naming `id`.
std::unique_ptr<Camera> OpenAravisCamera(const std::string& id);

// Every camera Aravis discovers (GigE Vision discovery broadcasts on every interface).
std::vector<CameraInfo> ListAravisCameras();

// Bits per pixel of a supported GenICam monochrome format ("Mono8" 8, "Mono10" 10, "Mono12" 12,
// "Mono14" 14, "Mono16" 16); 0 for any other (packed and colour formats are not supported).
int MonoBitDepth(const std::string& pixel_format);

}  // namespace fringe::capture
