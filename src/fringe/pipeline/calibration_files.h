// The calibration a command is given, and the one lookup every command uses to turn it into a
// rig: `fringe reconstruct`, `scan`, `refine` and `check` (and their library functions) take the
// same flags, read the same files the same way and name them the same way in their errors.
//
// Given (at most one kind):
//   calib                a rig JSON (.json: what `fringe calibrate` writes), or any other tool's
//                        calibration file io::ReadCalibration detects (OpenCV YAML/XML, SLStudio
//                        calibration.xml, SLMaster caliInfo.yml, ROS camera_info, Kalibr);
//   opencv               other tools' calibration file(s), read together (e.g. the left and right
//                        camera_info of ROS; format detected, or named with opencv_keys);
//   opencv_intrinsics +  OpenCV stereo_calib's pair (M1 D1 M2 D2 / R T, lengths in mm).
//   opencv_extrinsics
// Nothing given: the caller's defaults (a scan folder's rig.json, a view's rig.json).
//
// Thread safety: reentrant.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "fringe/geometry/stereo_rig.h"

namespace fringe::pipeline {

struct CalibrationFiles {
  std::filesystem::path calib;
  std::vector<std::filesystem::path> opencv;
  std::filesystem::path opencv_intrinsics, opencv_extrinsics;
  // With other tools' files: which key holds what ("left=Kc,kc", io::CalibrationKeyMap), for
  // files no reader recognises; empty: the format is detected.
  std::vector<std::string> opencv_keys;

  bool empty() const;
  // Every file given, in the order read (for "an output must not be an input" checks).
  std::vector<std::filesystem::path> Files() const;
  // Throws fringe::Error("<owner>.<field> = <value>: ...") naming the flags too: the pair
  // incomplete, a rig JSON / --calib together with other files, keys without other tools' files.
  void Check(const char* owner = "CalibrationFiles") const;
};

// Which devices the rig must hold, for other tools' files (a rig JSON is taken as it is).
enum class RigDevices {
  kStereo,           // two cameras and right_from_left (OpenCvCalibration::ToRig)
  kCameraProjector,  // a camera and the projector (OpenCvCalibration::ToCameraProjectorRig)
  kAuto,             // stereo when the files hold a right camera and its extrinsics
};

struct RigReadOptions {
  RigDevices devices = RigDevices::kAuto;
  // Sizes, px, for files that do not store them (io::CalibrationReadOptions): the images', and
  // the scheme's projector (SLMaster stores none). 0: not known.
  int camera_width = 0, camera_height = 0;
  int projector_width = 0, projector_height = 0;
  // With kStereo: why two cameras are needed, for the error when the files hold one
  // ("PROJECT is a stereo scan"); empty: OpenCvCalibration::ToRig's message.
  std::string stereo_needed_by;
};

struct ResolvedRig {
  StereoRig rig;
  std::string source;  // the file(s) it came from, joined by " + "
};

// The rig `files` give (Check()ed first), else the first of `defaults` that exists (rig JSONs);
// std::nullopt when neither: the caller says what it looked for. Throws fringe::Error naming the
// file and the problem for a file that does not read.
std::optional<ResolvedRig> LookUpRig(const CalibrationFiles& files, const RigReadOptions& read,
                                     const std::vector<std::filesystem::path>& defaults = {});

}  // namespace fringe::pipeline
