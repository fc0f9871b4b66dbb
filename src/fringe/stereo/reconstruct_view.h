// One view to 3D: decode the fringe stacks (phase/decode.h), find correspondences and
// triangulate (a Correspondence, below), remove organized outliers (outliers.h), estimate grid
// normals (geometry/normals.h). One ViewReconstructor runs every kind of view; what differs
// between kinds is only the correspondence step:
//   - stereo (MakeStereoCorrespondence): left <-> right by absolute-phase crossings along
//     rectified rows (phase_matching.h); one scheme, vertical fringes;
//   - camera-projector (camera_projector.h): one camera against the calibrated projector, one
//     fringe direction (ray against the projector column / row) or both (two-ray triangulation);
//   - trinocular (camera_projector.h): stereo, plus the left pixels the right camera cannot see
//     (shadowed for it or outside its image) triangulated against the projector.
// The decoding before and the stages after correspondence are shared, so the outputs of every
// kind mean the same.
//
// Output: an organized point cloud on the LEFT camera grid, in the LEFT camera frame (the
// sensor frame), millimetres; quality = left fringe modulation (DN), intensity = left fringe
// background (texture, 0-255 scale), residual_px = the correspondence's residual (stereo: the
// reprojection residual of the triangulation; camera-projector: the round trip into the
// projector; pixels; also returned as an image beside the cloud), normals toward the sensor.
// Fusion weighs points by these (docs/formats.md).
//
// Only vertical fringes (absolute phase = projector column) can be matched along epipolar rows
// of a horizontal-baseline rig; stereo with other schemes is rejected with fringe::Error.
//
// Thread safety: a ViewReconstructor (and every Correspondence) is immutable after
// construction; Reconstruct() may be called concurrently. Results do not depend on the number
// of threads.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
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
  // The left camera's (first scheme's) decoding; decode_right: the right camera's, or in
  // camera-projector mode with two fringe directions the second direction's.
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
nlohmann::json ToJson(const ReconstructionSummary& s);

struct ViewReconstruction {
  OrganizedPointCloud cloud;      // LEFT grid, LEFT camera frame, mm
  cv::Mat reprojection_error_px;  // CV_32F on the left grid, NaN where no point
  // Decoded fringe background (texture) of each camera on its own grid, CV_32F, 0-255 scale:
  // the images marker detection looks at (registration/markers.h).
  cv::Mat texture_left, texture_right;
  // The left camera's absolute phase of the first scheme (CV_32F on the left grid, projector
  // pixels, NaN where not decoded): what the projector-column check of a projector-less rig
  // compares the points with (projector_columns.h). Shares the decoder's buffer.
  cv::Mat phase_left;
  // The right camera's absolute phase of the first scheme (stereo and trinocular; empty for one
  // camera), on the right grid: what the rig's refinement from a scan compares the points with
  // (pipeline/refine.h). Shares the decoder's buffer.
  cv::Mat phase_right;
  ReconstructionSummary summary;
};

// The decoded stacks of one view: per camera, one result per scheme (in the schemes' order).
struct DecodedView {
  std::vector<phase::DecodeResult> left, right;  // right: empty for one-camera kinds
  double texture_scale = 1;  // 255 / the decoder's full scale: texture on the 0-255 scale
};

// The correspondence step of a view reconstruction: from the decoded view to 3D points on the
// left camera grid. Implementations: MakeStereoCorrespondence (below),
// MakeCameraProjectorCorrespondence and MakeTrinocularCorrespondence (camera_projector.h).
class Correspondence {
 public:
  virtual ~Correspondence() = default;
  // "stereo", "camera-projector", "trinocular".
  virtual const char* Name() const = 0;
  // The cameras whose stacks it reads: left, and right when UsesRight().
  virtual const CameraModel& Left() const = 0;
  virtual bool UsesRight() const = 0;
  virtual const CameraModel* Right() const { return nullptr; }
  // Throws fringe::Error naming the scheme when the schemes do not suit it (count, directions).
  virtual void CheckSchemes(const std::vector<phase::PatternScheme>& schemes) const = 0;
  // On entry out->cloud is an empty cloud on the left grid and out->reprojection_error_px all
  // NaN (unless MakesCloud()); fills the valid points (position, quality, intensity), the
  // residual image and out->summary.matching. Every decoded stack has a valid pixel.
  virtual void Correspond(const std::vector<phase::PatternScheme>& schemes, const DecodedView& view,
                          ViewReconstruction* out) const = 0;
  // True when Correspond replaces out->cloud and out->reprojection_error_px with its own, so
  // the reconstructor does not prepare them (an organized cloud is ~70 MB of fresh memory).
  virtual bool MakesCloud() const { return false; }
};

// Stereo: left <-> right absolute-phase matching (phase_matching.h). Throws fringe::Error for
// a bad rig or options.
std::shared_ptr<const Correspondence> MakeStereoCorrespondence(const StereoRig& rig,
                                                               const MatchingOptions& options);

// Images of one view: left[i] / right[i] the camera's images of scheme i, in the scheme's
// order (CV_8U or CV_16U), camera-sized; right empty for one-camera kinds.
struct ViewStacks {
  ViewStacks() = default;
  ViewStacks(std::vector<std::vector<cv::Mat>> left_stacks,
             std::vector<std::vector<cv::Mat>> right_stacks)
      : left(std::move(left_stacks)), right(std::move(right_stacks)) {}
  std::vector<std::vector<cv::Mat>> left, right;
  // Further exposures of the same view, exposure-major: with S schemes,
  // more_left_exposures[e * S + k] is the left camera's stack of scheme k at exposure e + 1
  // (left[k] is exposure 0; one scheme: more_left_exposures[e]); phase::DecodeExposures
  // combines them per pixel. Empty: one exposure.
  std::vector<std::vector<cv::Mat>> more_left_exposures, more_right_exposures;
};

class ViewReconstructor {
 public:
  // Any correspondence with its schemes. Throws fringe::Error for bad schemes or options.
  ViewReconstructor(std::shared_ptr<const Correspondence> correspondence,
                    std::vector<phase::PatternScheme> schemes,
                    const ReconstructionOptions& options = {});
  // Stereo: throws fringe::Error for a bad rig, scheme or options, or a scheme without vertical
  // fringes.
  ViewReconstructor(const StereoRig& rig, const phase::PatternScheme& scheme,
                    const ReconstructionOptions& options = {});

  ViewReconstruction Reconstruct(const ViewStacks& stacks) const;
  // One scheme: images in the scheme's order (CV_8U or CV_16U), left and right camera sizes of
  // the rig; right empty for one-camera kinds.
  ViewReconstruction Reconstruct(const std::vector<cv::Mat>& left_images,
                                 const std::vector<cv::Mat>& right_images) const;
  // Each camera's stack at one or several exposures (phase::DecodeExposures combines them per
  // pixel); the rest as above.
  ViewReconstruction Reconstruct(const std::vector<std::vector<cv::Mat>>& left_exposures,
                                 const std::vector<std::vector<cv::Mat>>& right_exposures) const;

  const Correspondence& correspondence() const { return *correspondence_; }
  const std::vector<phase::PatternScheme>& schemes() const { return schemes_; }

 private:
  std::shared_ptr<const Correspondence> correspondence_;
  std::vector<phase::PatternScheme> schemes_;
  ReconstructionOptions options_;
};

// The stages after correspondence, shared by every correspondence kind: on entry out->cloud,
// out->reprojection_error_px and out->summary.matching hold the correspondence's result;
// removes organized outliers (footprints from focal_px, the camera's focal length), sets the
// residual of removed points to NaN, copies the residual into the cloud (PLY residual_px),
// estimates normals per `options`, and sets summary.points / status. ViewReconstructor calls
// it; it is public for callers that build a cloud themselves.
void FinishViewReconstruction(double focal_px, const ReconstructionOptions& options,
                              ViewReconstruction* out);

// One-off convenience.
ViewReconstruction ReconstructView(const StereoRig& rig, const phase::PatternScheme& scheme,
                                   const std::vector<cv::Mat>& left_images,
                                   const std::vector<cv::Mat>& right_images,
                                   const ReconstructionOptions& options = {});

}  // namespace fringe::stereo
