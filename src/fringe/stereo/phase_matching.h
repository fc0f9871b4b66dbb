// Subpixel absolute-phase stereo matching and triangulation to an organized point cloud.
//
// Inputs are the two cameras' absolute phase maps (CV_32F, projector pixels of VERTICAL fringes,
// i.e. the projector column, on the ORIGINAL distorted camera grids; NaN or mask 0 = invalid).
// For every valid left pixel, the right image's phase is searched along the epipolar line, which
// after rectification (rectification.h) is the rectified row through the left pixel: the right
// phase map is resampled once on the rectified grid; for the (fractional) rectified row v of the
// left pixel the phase crossing phi_right(u) = phi_left is located in the rows floor(v) and
// floor(v) + 1 by interpolating the phase between the bracketing samples (linear, or a local cubic
// through four samples) and the two crossings are interpolated linearly in v. This follows the
// phase-based stereo matching of fringe projection systems (e.g. Zhang & Yau, "Absolute phase-
// assisted three-dimensional data registration", 2006; the thesis, ch. 3): the phase is
// interpolated, not a matching cost.
//
// Rejections (each counted in the summary): no crossing, several crossings (ambiguous), phase
// not monotonic (a retreat from the run's extreme larger than max_reversal_gradients local phase
// gradients) / jump between neighbouring samples larger than max_step_gradients local gradients
// (a depth discontinuity or a fringe-order error), the crossings of
// the two bracketing rows disagreeing (discontinuity across rows), left-right inconsistency (the
// rectified LEFT row searched for the same phase must give back the left pixel), low modulation,
// failed triangulation, large reprojection residual, disagreement with the calibrated projector.
// Triangulation is done in the original distorted geometry (triangulation.h).
//
// Output: an OrganizedPointCloud on the LEFT camera grid, points in the LEFT camera frame (mm),
// quality = left fringe modulation (DN), intensity = left texture when given; plus per-pixel maps
// of the matched right pixel and the reprojection residual.
//
// Thread safety: a PhaseMatcher is immutable after construction; Match() may be called
// concurrently. Results do not depend on the number of threads.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/stereo/rectification.h"
#include "fringe/stereo/triangulation.h"

namespace fringe::stereo {

// One camera's decoded phase. Only `phase` is required.
struct PhaseImage {
  cv::Mat phase;       // CV_32F absolute phase in projector pixels; NaN = invalid
  cv::Mat mask;        // CV_8U, non-zero = valid; empty = all finite phases valid
  cv::Mat modulation;  // CV_32F fringe modulation in DN; empty = unknown
  cv::Mat texture;     // CV_32F or CV_8U grey value (0-255 scale) for the cloud; may be empty
};

enum class CrossingInterpolation {
  kLinear = 0,  // straight line between the two bracketing samples
  kCubic = 1,   // cubic through the four samples around the crossing (linear at run ends)
};

struct MatchingOptions {
  // Pixels whose left modulation is below this are skipped, DN, >= 0 (0: rely on the mask).
  double min_modulation = 0;
  // Thresholds along a rectified row are in units of the local phase gradient g (the median
  // |phase step| between neighbouring samples around a sample, noise included), not in
  // projector pixels, so that matching does not depend on the phase scale: the same matches
  // whether the camera samples the projector at 0.3 or 3 projector pixels per pixel.
  // A step larger than this many g is a discontinuity (depth step or fringe-order error);
  // matching never interpolates across it. > 0.
  double max_step_gradients = 6.0;
  // A run of samples turns (a new monotonic run starts at its extreme) when the phase retreats
  // from the run's extreme by more than this many g; smaller retreats are noise. Also the net
  // change that gives a new run its direction. [0, max_step_gradients).
  double max_reversal_gradients = 2.0;
  CrossingInterpolation interpolation = CrossingInterpolation::kLinear;
  // Largest difference of the crossings in the two rectified rows bracketing a left pixel,
  // rectified pixels, > 0.
  double max_row_crossing_diff_px = 3.0;
  // Left-right consistency tolerance, rectified pixels, > 0. Phase noise moves the back-match
  // by (phase noise) / (phase gradient), a few tenths of a pixel on real data.
  double max_lr_error_px = 1.0;
  // Points with a larger RMS reprojection residual are dropped, pixels, > 0.
  double max_reprojection_error_px = 1.0;
  // When the rig has a calibrated projector: the triangulated point must project into the
  // projector at the column given by its phase within this tolerance, projector pixels; 0 turns
  // the check off. It removes the matches that phase alone cannot tell from true ones: at
  // occlusions the same phase can occur once in each row on different surfaces.
  double max_projector_error_px = 1.0;
  // The summary warns when more than this fraction of the valid left pixels fail the
  // left-right check (long streaks of such failures mean the phase is not what the matcher
  // expects), [0, 1].
  double lr_warning_fraction = 0.03;
  // Points outside this depth range (left camera z) are dropped, mm, 0 <= min < max.
  double min_depth_mm = 1.0;
  double max_depth_mm = 1e5;
  // Midpoint only by default: matches lie on the same rectified row, so the two rays meet (to
  // the rectification's precision) and Gauss-Newton refinement moves points by < 1e-6 mm while
  // costing a third of the matching time. The reprojection residual is kept either way.
  TriangulationOptions triangulation = MidpointOnly();
  RectificationOptions rectification;

  static TriangulationOptions MidpointOnly() {
    TriangulationOptions t;
    t.refine_iterations = 0;
    return t;
  }

  void Check() const;
};

enum class MatchingStatus {
  kOk = 0,
  kNoValidPixels,  // no left pixel had a valid phase
  kNoPoints,       // valid pixels, but none was matched and kept
};
const char* ToString(MatchingStatus status);

struct MatchingSummary {
  MatchingStatus status = MatchingStatus::kOk;
  std::string message;    // why, when status is not kOk
  int left_valid = 0;     // left pixels with a valid phase (and enough modulation)
  int no_crossing = 0;    // the phase does not occur on the rectified right row
  int ambiguous = 0;      // it occurs more than once
  int discontinuity = 0;  // the two bracketing rows disagree
  int lr_inconsistent = 0;
  int triangulation_failed = 0;
  int large_residual = 0;
  int projector_inconsistent = 0;
  int out_of_depth_range = 0;
  // Trinocular use only (camera_projector.h): left pixels the right camera cannot see, added
  // from the left camera + projector (included in points).
  int projector_filled = 0;
  int points = 0;
  double mean_reprojection_error_px = 0;
  double time_s = 0;
  // Empty, or why the result deserves a look (e.g. many left-right rejections).
  std::string warning;
  bool ok() const { return status == MatchingStatus::kOk; }
  std::string BriefReport() const;
};

struct MatchResult {
  OrganizedPointCloud cloud;  // LEFT grid, LEFT camera frame
  cv::Mat right_px;           // CV_32FC2 matched original right pixel per left pixel, NaN if none
  cv::Mat reprojection_error_px;  // CV_32F per left pixel, NaN if none
  MatchingSummary summary;
};

class PhaseMatcher {
 public:
  // Precomputes the rectification and the left viewing rays. Throws for a bad rig / options.
  PhaseMatcher(const StereoRig& rig, const MatchingOptions& options = {});

  // Throws fringe::Error when an image's size or type does not fit the rig.
  MatchResult Match(const PhaseImage& left, const PhaseImage& right) const;

  const Rectification& rectification() const { return rect_; }
  const MatchingOptions& options() const { return options_; }

 private:
  StereoRig rig_;
  MatchingOptions options_;
  Rectification rect_;
  RayTriangulator triangulator_;
  cv::Mat left_rect_px_;  // CV_32FC2: rectified pixel of every original left pixel
  cv::Mat left_rays_;     // CV_32FC3: unit viewing ray of every original left pixel
};

namespace internal {
// One monotonic run of a rectified row, as the matcher finds them (exposed for tests).
struct PhaseRun {
  int begin = 0;  // first sample
  int end = 0;    // last sample, > begin
  bool increasing = true;
};
// The runs of one row of rectified phase (NaN = invalid) under options' step and reversal
// thresholds.
std::vector<PhaseRun> RowRuns(const std::vector<float>& row, const MatchingOptions& options);
}  // namespace internal

// One-off convenience.
MatchResult MatchPhase(const StereoRig& rig, const PhaseImage& left, const PhaseImage& right,
                       const MatchingOptions& options = {});

}  // namespace fringe::stereo
