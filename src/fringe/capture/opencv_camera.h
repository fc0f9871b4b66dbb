// The OpenCV VideoCapture backend (V4L2): UVC webcams. Internal to the capture module; use
// OpenCamera("opencv:N") (camera.h).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "fringe/capture/camera.h"

namespace fringe::capture {

// Opens V4L2 device `index` (/dev/video<index>). Throws fringe::Error when it cannot be opened.
std::unique_ptr<Camera> OpenOpenCvCamera(int index);

// V4L2 devices /dev/video0 .. /dev/video<max_index> that open and deliver a frame size.
std::vector<CameraInfo> ListOpenCvCameras(int max_index = 9);

}  // namespace fringe::capture
