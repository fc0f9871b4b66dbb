// One view to 3D: decode both cameras' fringe stacks (phase/decode.h), match the absolute phase
// along rectified rows and triangulate (phase_matching.h), remove organized outliers
// (outliers.h), estimate grid normals (geometry/normals.h).
//
// Output: an organized point cloud on the LEFT camera grid, in the LEFT camera frame (the
// sensor frame), millimetres; quality = left fringe modulation (DN), intensity = left fringe
// background (texture, 0-255 scale), residual_px = reprojection residual of the triangulation
// (pixels; also returned as an image beside the cloud), normals toward the sensor. Fusion
// weighs points by these (docs/formats.md).
//
// Only vertical fringes (absolute phase = projector column) can be matched along epipolar rows
// of a horizontal-baseline rig; other schemes are rejected with fringe::Error. The single-camera
// mode (one camera + the calibrated projector, either fringe direction or both) is
// stereo/camera_projector.h; both modes share the stages after correspondence
// (FinishViewReconstruction below), so their outputs mean the same.
//
// Thread safety: a ViewReconstructor is immutable after construction; Reconstruct() may be
// called concurrently. Results do not depend on the number of threads.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/normals.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/stereo/outliers.h"
#include "fringe/stereo/phase_matching.h"

namespace fringe::stereo {

struct ReconstructionOptions {
  phase::DecodeOptions decode;
  MatchingOptions matching;
  bool remove_outliers = true;
  OutlierOptions outliers;  // footprints from the rig's left focal length
  bool compute_normals = true;
  GridNormalOptions normals;
  void Check() const;
};

enum class ReconstructionStatus {
  kOk = 0,
  kNoValidPixels,  // the decoder found no valid pixel in one of the cameras
  kNoPoints,       // decoding worked but no pixel was matched and kept
};
const char* ToString(ReconstructionStatus s);

struct ReconstructionSummary {
  ReconstructionStatus status = ReconstructionStatus::kOk;
  std::string message;
  phase::DecodeSummary decode_left, decode_right;
  MatchingSummary matching;
  OutlierSummary outliers;
  GridNormalSummary normals;
  int points = 0;
  double decode_s = 0, match_s = 0, outliers_s = 0, normals_s = 0, total_s = 0;
  bool ok() const { return status == ReconstructionStatus::kOk; }
  std::string BriefReport() const;
};
// Every figure of the summary (decode as in `fringe decode`'s summary.json, matching, outliers,
// normals, timings) with each stage's one-line report, for scripts (the Python bindings).
nlohmann::json SummaryToJson(const ReconstructionSummary& s);

struct ViewReconstruction {
  OrganizedPointCloud cloud;      // LEFT grid, LEFT camera frame, mm
  cv::Mat reprojection_error_px;  // CV_32F on the left grid, NaN where no point
  // Decoded fringe background (texture) of each camera on its own grid, CV_32F, 0-255 scale:
  // the images marker detection looks at (registration/markers.h).
  cv::Mat texture_left, texture_right;
  ReconstructionSummary summary;
};

class ViewReconstructor {
 public:
  // Throws fringe::Error for a bad rig, scheme or options, or a scheme without vertical fringes.
  ViewReconstructor(const StereoRig& rig, const phase::PatternScheme& scheme,
                    const ReconstructionOptions& options = {});
  // Images in the scheme's order (CV_8U or CV_16U), left and right camera sizes of the rig.
  ViewReconstruction Reconstruct(const std::vector<cv::Mat>& left_images,
                                 const std::vector<cv::Mat>& right_images) const;
  // Each camera's stack at one or several exposures (phase::DecodeExposures combines them per
  // pixel); the rest as above.
  ViewReconstruction Reconstruct(const std::vector<std::vector<cv::Mat>>& left_exposures,
                                 const std::vector<std::vector<cv::Mat>>& right_exposures) const;

 private:
  StereoRig rig_;
  phase::PatternScheme scheme_;
  ReconstructionOptions options_;
  PhaseMatcher matcher_;
};

// The stages after correspondence, shared by every correspondence kind (stereo matching,
// camera-projector): on entry out->cloud, out->reprojection_error_px and
// out->summary.matching hold the correspondence's result; removes organized outliers (footprints
// from focal_px, the camera's focal length), sets the residual of removed points to NaN, copies
// the residual into the cloud (PLY residual_px), estimates normals per `options`, and sets
// summary.points / status.
void FinishViewReconstruction(double focal_px, const ReconstructionOptions& options,
                              ViewReconstruction* out);

// One-off convenience.
ViewReconstruction ReconstructView(const StereoRig& rig, const phase::PatternScheme& scheme,
                                   const std::vector<cv::Mat>& left_images,
                                   const std::vector<cv::Mat>& right_images,
                                   const ReconstructionOptions& options = {});

}  // namespace fringe::stereo
