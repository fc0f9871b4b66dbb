// Calibration files written by OpenCV-based tools (cv::FileStorage's YAML / XML): any subset of
// devices (two cameras + extrinsics, one camera + projector + extrinsics, or all three) under
// the usual key spellings, e.g.
//   left camera   M1 K1 cameraMatrix1 cameraMatrixL camera_matrix_left ... / D1 distCoeffs1 ...
//   right camera  M2 K2 cameraMatrix2 cameraMatrixR camera_matrix_right ... / D2 distCoeffs2 ...
//   projector     M3 M4 Kp K_p projectorMatrix cameraMatrixP ... / D3 D4 Dp projectorDistCoeffs
//   right_from_left      R T, Rlr Tlr, R_l2r T_l2r, R_lr T_lr, R12 T12
//   projector_from_left  Rlp Tlp, R_l2p T_l2p, R_lp T_lp, R13 T13, Rp Tp
// (docs/formats.md lists them all). Rectification outputs (R1 R2 P1 P2 Q) are not extrinsics
// and are never taken for them. Translations are in the file's length unit, taken as mm.
// Distortion: fringe's model is OpenCV's k1 k2 p1 p2 [k3]; longer vectors (8, 12, 14
// coefficients: rational, thin-prism, tilt models) are an error unless the extra coefficients
// are exactly zero, never silently truncated.
//
// Files are untrusted: they are parsed by yaml-cpp / tinyxml2 with explicit size, depth and
// count limits (io/text_tree.h), never by cv::FileStorage (OpenCV is used only to write them).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "fringe/geometry/camera.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/geometry/stereo_rig.h"

namespace fringe::io {

struct OpenCvCalibration {
  std::optional<CameraModel> left, right, projector;
  std::optional<Rigid3d> right_from_left, projector_from_left;
  // What was read from where, e.g. "intrinsic.yml: M1 -> left camera matrix", and notes.
  std::vector<std::string> keys_used;
  // The reader that read the files: "opencv", "slstudio", "ros", "kalibr" or "keys" (an explicit
  // mapping), io/calibration_formats.h.
  std::string format;

  // The rig fringe reconstructs with: needs both cameras and right_from_left (the projector is
  // kept when present with projector_from_left). Throws fringe::Error naming `context` and what
  // is missing.
  StereoRig ToRig(const std::string& context) const;
  // The rig of camera-projector mode (stereo/camera_projector.h): needs the left camera, the
  // projector and projector_from_left; a right camera is kept when present, else `right` is a
  // copy of the left at zero baseline (as a single-camera rig file reads, io/calibration_io.h).
  StereoRig ToCameraProjectorRig(const std::string& context) const;
  // Devices and keys, one per line (for `fringe info` and the reconstruct log).
  std::string Describe() const;
};

// Reads the devices from one or more calibration files of any format fringe knows
// (io/calibration_formats.h: this file's OpenCV spellings, SLStudio, ROS camera_info, Kalibr),
// detecting which; a file set that two readers match is an error naming both.
OpenCvCalibration ReadOpenCvCalibration(const std::vector<std::filesystem::path>& files,
                                        int camera_width = 0, int camera_height = 0,
                                        int projector_width = 0, int projector_height = 0);

// The OpenCV reader proper (OpenCV's YAML / XML files under the usual spellings above).
// Reads the devices from one or more files (stereo_calib writes intrinsics and extrinsics
// separately; a key found in two files is an error). Image sizes come from the files when they
// hold them (image_width/image_height, imageSize, image_size, width/height; the projector's
// from projector_width/projector_height, projectorSize, projector_size), else from
// camera_width/height (> 0; -1: assume twice the principal point, for descriptions only); a
// projector of unknown size takes projector_width/height when given (> 0: e.g. the pattern
// scheme's projector size), else it is dropped with a note.
OpenCvCalibration ReadOpenCvKeySpellings(const std::vector<std::filesystem::path>& files,
                                         int camera_width = 0, int camera_height = 0,
                                         int projector_width = 0, int projector_height = 0);

// The spellings of the (left) camera matrix the reader above looks for, most common first.
const std::vector<std::string>& OpenCvCameraMatrixSpellings();

// The checks and conversions every calibration reader shares (this one, io/calibration_formats.h):
// a camera from a row-major 3x3 matrix [fx 0 cx; 0 fy cy; 0 0 1] and OpenCV's distortion vector
// (4, 5, or 8/12/14 with the extra coefficients exactly 0; nullptr: none), Check()ed and
// plausible; a rigid transform from a 3x3 rotation (or a Rodrigues 3-vector) and a translation
// multiplied by mm_per_unit. Errors name `*_where` (file and key) and the device.
CameraModel CameraFromMatrices(const std::vector<double>& k, const std::vector<double>* d,
                               int width, int height, const std::string& device,
                               const std::string& k_where, const std::string& d_where);
Rigid3d RigidFromMatrices(const std::vector<double>& r, const std::vector<double>& t,
                          double mm_per_unit, const std::string& what, const std::string& r_where,
                          const std::string& t_where);

}  // namespace fringe::io
