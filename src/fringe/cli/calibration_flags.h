// The calibration flags shared by `fringe reconstruct`, `scan`, `refine` and `check`: one
// spelling for one input across commands, read by one lookup (pipeline/calibration_files.h).
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "fringe/pipeline/calibration_files.h"

namespace fringe::cli {

// Adds --calib, --opencv (repeatable), --opencv-keys and the --opencv-intrinsics /
// --opencv-extrinsics pair to `sub`, bound to `files`. `fallback`: what is used when none is
// given ("the scan folder's rig.json").
inline void AddCalibrationFlags(CLI::App* sub, pipeline::CalibrationFiles* files,
                                const std::string& fallback) {
  sub->add_option("--calib", files->calib,
                  "Rig calibration: a rig JSON (what fringe calibrate writes) or another tool's "
                  "calibration file (as --opencv); default: " +
                      fallback);
  sub->add_option("--opencv", files->opencv,
                  "Instead of --calib: other tools' calibration file(s), read together, format "
                  "detected (OpenCV YAML/XML, SLStudio calibration.xml, SLMaster caliInfo.yml, "
                  "ROS left + right camera_info, Kalibr camchain); may be repeated")
      ->expected(1, 4);
  sub->add_option("--opencv-keys", files->opencv_keys,
                  "With --opencv, for files no reader recognises: which key holds what, e.g. "
                  "left=Kc,kc projector=Kp,kp projector_from_left=Rp,Tp "
                  "left_size=frameWidth,frameHeight")
      ->expected(1, 16);
  sub->add_option("--opencv-intrinsics", files->opencv_intrinsics,
                  "Instead of --calib: OpenCV stereo intrinsics (M1 D1 M2 D2, YAML/XML)");
  sub->add_option("--opencv-extrinsics", files->opencv_extrinsics,
                  "With --opencv-intrinsics: OpenCV stereo extrinsics (R T, millimetres)");
}

}  // namespace fringe::cli
