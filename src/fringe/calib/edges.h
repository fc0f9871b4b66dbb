// Subpixel edge points from the image gradient.
//
// Method (the thesis' edge locator): smooth the image with a small Gaussian, take the gradient
// (3x3 Sobel), and across each edge sample the gradient magnitude along the gradient direction;
// fit a second-order polynomial to the logarithm of the three samples around the maximum (a
// Gaussian profile, which a blurred step's derivative is) and take its vertex as the edge. The
// log-domain fit removes the bias a plain parabola has when the true peak lies between samples.
// A second pass re-centres the samples on the first estimate.
//
// Pixels: centre of the top-left pixel at (0, 0) (docs/conventions.md).
// Thread safety: GradientImage is immutable after construction; LocateEdge may run concurrently.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>

namespace fringe::calib {

struct EdgeOptions {
  double smoothing_sigma_px = 1.0;    // Gaussian pre-smoothing, px, [0, 5]
  double search_half_width_px = 4.0;  // search range along the expected normal, px, (0, 50]
  double min_gradient = 3.0;          // minimum gradient magnitude at the edge, DN/px, >= 0
  double max_angle_deg = 40.0;        // gradient vs expected normal, degrees, (0, 90]
  void Check() const;
};

// Smoothed gradient of a grey image (CV_8U, CV_16U or CV_32F), with bilinear look-ups.
class GradientImage {
 public:
  GradientImage(const cv::Mat& gray, double smoothing_sigma_px);
  int width() const { return gx_.cols; }
  int height() const { return gx_.rows; }
  // Bilinearly interpolated gradient (DN/px); zero outside the image.
  Eigen::Vector2d Gradient(const Eigen::Vector2d& p) const;
  // Bicubic (cubic convolution) interpolated gradient, for the subpixel fit.
  Eigen::Vector2d GradientCubic(const Eigen::Vector2d& p) const;
  // Bilinearly interpolated smoothed intensity.
  double Intensity(const Eigen::Vector2d& p) const;
  bool Inside(const Eigen::Vector2d& p, double margin_px) const {
    return p.x() >= margin_px && p.y() >= margin_px && p.x() <= width() - 1 - margin_px &&
           p.y() <= height() - 1 - margin_px;
  }

 private:
  cv::Mat smooth_, gx_, gy_;  // CV_32F
};

struct EdgePoint {
  Eigen::Vector2d position;  // px
  Eigen::Vector2d normal;    // unit gradient direction (dark to bright)
  double strength = 0;       // gradient magnitude at the edge, DN/px
};

// The edge crossing the line seed + t * normal, |t| <= search_half_width_px, whose gradient
// points along +normal (dark to bright). nullopt when there is none (too weak, wrong direction,
// too close to the image border).
std::optional<EdgePoint> LocateEdge(const GradientImage& gradient, const Eigen::Vector2d& seed,
                                    const Eigen::Vector2d& normal, const EdgeOptions& options);

}  // namespace fringe::calib
