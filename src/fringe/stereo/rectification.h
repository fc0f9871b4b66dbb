// Stereo rectification of a calibrated rig (Bouguet-style: both cameras rotated about their
// centres onto a common orientation whose x axis is the baseline).
//
// Frames (docs/conventions.md for the camera frames):
// - "rect" frame: origin at the LEFT camera centre, rotation rect_from_left() from the left
//   camera frame; x along the baseline (left centre -> right centre), z the mean of the two
//   optical axes made orthogonal to x, y = z cross x (down, as in the cameras).
// - The right rectified camera has the same orientation, centred at the right camera centre,
//   i.e. at (baseline_mm, 0, 0) in the rect frame.
// - Rectified pixels: u = f * X/Z + cx_{left|right}, v = f * Y/Z + cy with one focal length f and
//   one cy for both cameras, so corresponding points share the row v. Each camera has its own cx
//   and image width so that its whole original image fits (no pixel is lost, focal not shrunk):
//   disparity (u_left - u_right) = f * baseline / Z + (cx_left - cx_right).
// Original pixels are the cameras' distorted pixels. Mappings between original and rectified
// pixels are exact (CameraModel's Newton undistortion), not table lookups.
//
// Thread safety: a computed Rectification is immutable; const methods are safe concurrently.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "fringe/geometry/stereo_rig.h"

namespace fringe::stereo {

struct RectificationOptions {
  // Rectified focal length = mean of the four original focal lengths times this, in (0, 4].
  // 1 keeps about the original sampling density.
  double focal_scale = 1.0;
  void Check() const;
};

enum class Side { kLeft = 0, kRight = 1 };

class Rectification {
 public:
  Rectification() = default;
  // Throws fringe::Error for an invalid rig or options.
  Rectification(const StereoRig& rig, const RectificationOptions& options = {});

  const StereoRig& rig() const { return rig_; }
  const Eigen::Matrix3d& rect_from_left() const { return rect_from_left_; }
  // Rotation from the right camera frame to the (right) rectified orientation.
  const Eigen::Matrix3d& rect_from_right() const { return rect_from_right_; }
  double focal_px() const { return f_; }
  double baseline_mm() const { return baseline_mm_; }
  double cx(Side s) const { return cx_[static_cast<int>(s)]; }
  double cy() const { return cy_; }
  // Size of the rectified image of a camera (both have the same height).
  cv::Size size(Side s) const { return size_[static_cast<int>(s)]; }

  // Rectified pixel of an original (distorted) pixel, and back.
  Eigen::Vector2d RectifiedFromOriginal(Side s, const Eigen::Vector2d& original_px) const;
  Eigen::Vector2d OriginalFromRectified(Side s, const Eigen::Vector2d& rectified_px) const;
  // Undistorted normalized coordinates (x/z, y/z in camera s's own frame) of the ray through a
  // rectified pixel: exact, no undistortion iterations.
  Eigen::Vector2d NormalizedFromRectified(Side s, const Eigen::Vector2d& rectified_px) const;
  // Rectified pixel of a point given in the LEFT camera frame (Z must be > 0 in that camera).
  Eigen::Vector2d ProjectRectified(Side s, const Eigen::Vector3d& p_in_left) const;

  // For every rectified pixel of a camera, the original pixel it comes from (CV_32FC2, like
  // cv::initUndistortRectifyMap's output); computed by the constructor.
  const cv::Mat& OriginalFromRectifiedMap(Side s) const { return maps_[static_cast<int>(s)]; }

  // Resamples a single-channel CV_32F image of camera s (original pixels) on its rectified grid
  // by bilinear interpolation in double precision. A rectified pixel whose 4 source neighbours
  // are not all finite (NaN marks invalid) or which falls outside the image is NaN.
  cv::Mat RectifyFloat(Side s, const cv::Mat& original) const;

 private:
  StereoRig rig_;
  Eigen::Matrix3d rect_from_left_ = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d rect_from_right_ = Eigen::Matrix3d::Identity();
  double f_ = 0, cy_ = 0, baseline_mm_ = 0;
  double cx_[2] = {0, 0};
  cv::Size size_[2];
  cv::Mat maps_[2];
};

// Bilinear sample of a CV_32F image at a subpixel position; NaN when outside the image or when
// any of the 4 neighbours is not finite.
double SampleBilinear(const cv::Mat& image, double x, double y);

}  // namespace fringe::stereo
