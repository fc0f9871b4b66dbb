// Calibration files of other tools, read and written (docs/formats.md, "Calibration files of
// other tools"). Every reader fills the same OpenCvCalibration (devices, keys used, format), so
// `--opencv`, `fringe info` and `fringe convert-calib` take any of them:
//
//  opencv    cv::FileStorage YAML/XML under the usual spellings (io/opencv_calibration.h):
//            stereo_calib, SLMaster caliInfo.yml, SL-SDK intrinsic.yml + extrinsic.yml. Lengths
//            in the file's unit, taken as mm.
//  slstudio  SLStudio's calibration.xml (CalibrationData::saveXML, an OpenCV XML file): camera
//            Kc/kc, projector Kp/kp, Rp/Tp = projector_from_camera (SLStudio's triangulator
//            projects with Kp [Rp | Tp]), camera size frameWidth x frameHeight, projector size
//            screenResX x screenResY; lengths in mm (SLStudio's board sizes are mm).
//  ros       ROS camera_info YAML (camera_calibration_parsers): image_width, image_height,
//            camera_matrix, distortion_model (plumb_bob / rational_polynomial with zero extra
//            terms), distortion_coefficients, rectification_matrix R, projection_matrix P. A
//            stereo pair is two files: the left's P has P[0][3] = 0, the right's
//            P[0][3] = -fx' B (B in metres, ROS's unit); right_from_left = R_r^T (R_l x +
//            (P_r[0][3] / fx', P_r[1][3] / fy', 0) * 1000 mm).
//  kalibr    Kalibr camchain.yaml: camN {camera_model: pinhole, intrinsics [fu fv pu pv],
//            distortion_model radtan (k1 k2 r1 r2) or none, distortion_coeffs, resolution [w h],
//            T_cn_cnm1 (4x4, camera n from camera n-1, metres)}. cam0 is the left camera; the
//            projector is the camera whose rostopic names "projector", else cam2 of three; the
//            right camera is the remaining one.
//  keys      an explicit mapping for any other YAML/XML file (CalibrationKeyMap).
//
// Detection (ReadCalibration): each reader has a signature (slstudio: Kc, Kp, Rp and Tp; ros:
// camera_matrix, rectification_matrix and projection_matrix; kalibr: cam0 with intrinsics;
// opencv: a cv::FileStorage header and one of its camera-matrix spellings). Exactly one must
// match the files; two matching is an error naming both (resolve with an explicit mapping).
//
// Every reader parses with yaml-cpp / tinyxml2 under explicit limits (io/text_tree.h); OpenCV's
// own parser never sees an untrusted file (cv::FileStorage only writes the opencv format).
//
// Writers (WriteCalibration) produce files the tools read, with 17 significant digits, so a rig
// written and read back is equal to 1e-12. Files are written atomically.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fringe/geometry/stereo_rig.h"
#include "fringe/io/opencv_calibration.h"

namespace fringe::io {

enum class CalibrationFormat { kOpenCv, kSlStudio, kRos, kKalibr };
const char* CalibrationFormatName(CalibrationFormat format);  // "opencv", "slstudio", ...
// Throws fringe::Error listing the names when `name` is none of them.
CalibrationFormat ParseCalibrationFormat(const std::string& name);

// `--opencv-keys left=Kc,kc projector=Kp,kp projector_from_left=Rp,Tp`: which key holds what.
// Targets: left, right, projector (camera matrix[, distortion]); right_from_left,
// projector_from_left (rotation, translation in mm); left_size, projector_size (width, height
// integer keys, or one key holding [width, height]). Only the listed devices are read.
struct CalibrationKeyMap {
  std::vector<std::pair<std::string, std::vector<std::string>>> entries;  // target -> keys
  bool empty() const { return entries.empty(); }
  const std::vector<std::string>* Find(const std::string& target) const;
  // Parses "target=key[,key]" arguments; throws fringe::Error naming a bad argument.
  static CalibrationKeyMap Parse(const std::vector<std::string>& args);
};

// SLStudio's keys as a mapping (its reader is the mapping reader with these keys).
CalibrationKeyMap SlStudioKeys();

struct CalibrationReadOptions {
  // Sizes when the files do not hold them (as ReadOpenCvKeySpellings; -1: twice the principal
  // point, for descriptions only).
  int camera_width = 0, camera_height = 0;
  int projector_width = 0, projector_height = 0;
  CalibrationKeyMap keys;  // non-empty: read exactly these keys, no detection
};

// Detects the format (above) and reads. Throws fringe::Error naming the files when none or two
// readers match, and whatever the reader throws (naming file and key).
OpenCvCalibration ReadCalibration(const std::vector<std::filesystem::path>& files,
                                  const CalibrationReadOptions& options = {});

// The formats whose signature `files` match (for the error message and tests).
std::vector<CalibrationFormat> DetectCalibrationFormats(
    const std::vector<std::filesystem::path>& files);

// Writes `rig` in `format`: opencv one YAML file (M1 D1 [M2 D2 R T] [Kp Dp Rlp Tlp], sizes);
// slstudio calibration.xml (left camera + projector; a right camera cannot be stored: noted);
// ros two camera_info files, left then right (cameras only: a projector is noted as not stored);
// kalibr one camchain.yaml (cam0 left, cam1 right, then the projector with rostopic
// /projector/image_raw; a single-camera rig: cam0 camera, cam1 projector). A single-camera rig
// (right at zero baseline) has no right camera. Throws fringe::Error (before writing anything)
// when the rig cannot be stored: wrong number of outputs, no projector for slstudio, k3 != 0 for
// kalibr's radtan, cameras of different sizes for opencv. Returns notes to print.
std::vector<std::string> WriteCalibration(CalibrationFormat format,
                                          const std::vector<std::filesystem::path>& outputs,
                                          const StereoRig& rig);
// Number of output files `format` writes (ros: 2, others: 1).
int CalibrationOutputCount(CalibrationFormat format);

}  // namespace fringe::io
