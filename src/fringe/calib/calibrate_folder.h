// Calibration of an image folder, as run by `fringe calibrate DIR --target T --out OUT`:
// DIR holds left/ and right/ folders (pairs matched by file name) or the images of a single
// camera. Images: png, jpg, jpeg, tif, tiff, bmp (8 or 16 bit grey or colour).
// Output: the rig JSON (docs/formats.md; a single camera as {"camera": {...}}) with extra keys
// "calibration" (RMS, standard deviations, per-view residuals, epipolar statistics).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/calib/calibrate.h"
#include "fringe/calib/detect.h"

namespace fringe::calib {

struct FolderCalibration {
  bool stereo = false;
  std::vector<std::string> names;  // image file names (per pair for stereo)
  std::vector<TargetDetection> left, right;
  CameraCalibration mono;  // single camera
  StereoCalibration pair;  // stereo
  bool success() const { return stereo ? pair.summary.ok() : mono.summary.ok(); }
  // Readable multi-line summary: RMS, per-view errors, rejected views, coverage.
  std::string Report() const;
};

// Throws fringe::Error for a missing folder, no images, unpaired left/right images or an
// unreadable image (naming the file).
FolderCalibration CalibrateFolder(const std::filesystem::path& dir, const CalibrationTarget& target,
                                  const CalibrationOptions& options = {},
                                  const DetectionOptions& detection = {});

// The "calibration" object of the written file: RMS, standard deviations, per-view residuals
// (and for a pair the epipolar statistics and the extrinsic standard deviations).
nlohmann::json CalibrationToJson(const FolderCalibration& result);

// Writes the calibration (atomically).
void WriteFolderCalibration(const std::filesystem::path& path, const FolderCalibration& result);

// Every detected centre of every view and camera, for checking detections: per feature the
// camera ("camera" for a single one, "left"/"right" for a pair), view index and name, board
// row, column and feature index (row * cols + col, the target's order), the detected centre
// ("raw", detect.h) and, in views the calibration used, the centre after the last
// bias-correcting re-measurement ("corrected", calibrate.h) with its reprojection residual
// (observed - projected). JSON: {"format": "fringe-centres", "version": 1, "centres": [...]},
// corrected/residual null in unused views; CSV: one header line, then one line per feature,
// corrected/residual empty in unused views.
nlohmann::json CentresToJson(const FolderCalibration& result, const CalibrationTarget& target);
// Writes CentresToJson's table as CSV or JSON (atomically), chosen by the file's extension
// (.csv, .json; anything else is an error naming the file).
void WriteCentres(const std::filesystem::path& path, const FolderCalibration& result,
                  const CalibrationTarget& target);
// Throws fringe::Error naming the file when its extension is neither .csv nor .json (checked
// before a calibration starts).
void CheckCentresPath(const std::filesystem::path& path);

// Colour image of one camera's residual vectors (magnified by `scale`; 0: automatic, the RMS
// drawn as 1.5 % of the width) at every feature, with the covered region (convex hulls of the
// boards) shaded.
cv::Mat ResidualImage(const CameraCalibration& cal, double scale = 0);

}  // namespace fringe::calib
