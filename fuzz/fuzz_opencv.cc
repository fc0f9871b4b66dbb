// OpenCV calibration YAML / XML import (yaml-cpp / tinyxml2 with limits, then key lookup).
#include "fringe/io/opencv_calibration.h"
#include "fringe/util/error.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // The extension selects OpenCV's parser: alternate YAML and XML on the first byte.
  const bool xml = size > 0 && (data[0] & 1);
  const auto path = fringe::fuzz::InputFile(data, size, xml ? "calib.xml" : "calib.yml");
  try {
    fringe::io::ReadOpenCvCalibration({path}, 640, 480);
  } catch (const fringe::Error&) {
  }
  return 0;
}
