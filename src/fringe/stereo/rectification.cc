#include "fringe/stereo/rectification.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "fringe/util/error.h"

namespace fringe::stereo {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

const CameraModel& Camera(const StereoRig& rig, Side s) {
  return s == Side::kLeft ? rig.left : rig.right;
}

}  // namespace

void RectificationOptions::Check() const {
  util::CheckOption(focal_scale > 0 && focal_scale <= 4, "RectificationOptions", "focal_scale",
                    focal_scale, "must be in (0, 4]");
}

double SampleBilinear(const cv::Mat& image, double x, double y) {
  if (!(x >= 0 && y >= 0 && x <= image.cols - 1 && y <= image.rows - 1)) return kNaN;
  int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  // On the last column/row use the cell to the left/above so that x1/y1 stay inside.
  if (x0 == image.cols - 1 && x0 > 0) --x0;
  if (y0 == image.rows - 1 && y0 > 0) --y0;
  const int x1 = std::min(x0 + 1, image.cols - 1), y1 = std::min(y0 + 1, image.rows - 1);
  const double ax = x - x0, ay = y - y0;
  const float* r0 = image.ptr<float>(y0);
  const float* r1 = image.ptr<float>(y1);
  const double v00 = r0[x0], v01 = r0[x1], v10 = r1[x0], v11 = r1[x1];
  const double top = v00 + ax * (v01 - v00);
  const double bottom = v10 + ax * (v11 - v10);
  return top + ay * (bottom - top);  // NaN propagates from any neighbour
}

Rectification::Rectification(const StereoRig& rig, const RectificationOptions& options)
    : rig_(rig) {
  rig.Check();
  options.Check();
  const Rigid3d left_from_right = rig.right_from_left.Inverse();
  const Eigen::Vector3d c_right = left_from_right.translation();
  baseline_mm_ = c_right.norm();
  const Eigen::Vector3d ex = c_right / baseline_mm_;
  const Eigen::Vector3d z_mean =
      Eigen::Vector3d::UnitZ() + left_from_right.RotateDirection(Eigen::Vector3d::UnitZ());
  Eigen::Vector3d ez = z_mean - z_mean.dot(ex) * ex;
  util::CheckOption(ez.norm() > 1e-6, "StereoRig", "right_from_left", "optical axes",
                    "the baseline must not be along the optical axes");
  ez.normalize();
  const Eigen::Vector3d ey = ez.cross(ex);
  rect_from_left_.row(0) = ex.transpose();
  rect_from_left_.row(1) = ey.transpose();
  rect_from_left_.row(2) = ez.transpose();
  rect_from_right_ = rect_from_left_ * left_from_right.rotation_matrix();
  f_ = options.focal_scale * 0.25 * (rig.left.fx + rig.left.fy + rig.right.fx + rig.right.fy);

  // Bounds of each original image in rectified normalized coordinates (sampled boundary).
  double y_min = 1e300, y_max = -1e300;
  double x_min[2], x_max[2];
  for (int s = 0; s < 2; ++s) {
    const CameraModel& cam = Camera(rig, static_cast<Side>(s));
    const Eigen::Matrix3d& rot = s == 0 ? rect_from_left_ : rect_from_right_;
    x_min[s] = 1e300;
    x_max[s] = -1e300;
    auto add = [&](double u, double v) {
      const Eigen::Vector2d xy = cam.Unproject({u, v});
      const Eigen::Vector3d d = rot * Eigen::Vector3d(xy.x(), xy.y(), 1.0);
      util::CheckOption(d.z() > 0, "StereoRig", "cameras", "field of view",
                        "the rectified view of an image must stay in front of the camera");
      x_min[s] = std::min(x_min[s], d.x() / d.z());
      x_max[s] = std::max(x_max[s], d.x() / d.z());
      y_min = std::min(y_min, d.y() / d.z());
      y_max = std::max(y_max, d.y() / d.z());
    };
    const double w = cam.width - 0.5, h = cam.height - 0.5;
    for (double u = -0.5; u <= w; u += 4) add(u, -0.5), add(u, h);
    for (double v = -0.5; v <= h; v += 4) add(-0.5, v), add(w, v);
    add(w, h);
  }
  // Pixel centres at integers: the first column's centre sits at x_min (half a pixel margin).
  for (int s = 0; s < 2; ++s) {
    cx_[s] = -f_ * x_min[s] + 0.5;
    size_[s].width = static_cast<int>(std::ceil(f_ * (x_max[s] - x_min[s]))) + 1;
  }
  cy_ = -f_ * y_min + 0.5;
  size_[0].height = size_[1].height = static_cast<int>(std::ceil(f_ * (y_max - y_min))) + 1;

  for (int s = 0; s < 2; ++s) {
    const Side side = static_cast<Side>(s);
    maps_[s].create(size_[s], CV_32FC2);
    tbb::parallel_for(tbb::blocked_range<int>(0, size_[s].height), [&](const auto& rows) {
      for (int v = rows.begin(); v < rows.end(); ++v) {
        auto* row = maps_[s].ptr<cv::Vec2f>(v);
        for (int u = 0; u < size_[s].width; ++u) {
          const Eigen::Vector2d o = OriginalFromRectified(side, Eigen::Vector2d(u, v));
          row[u] = cv::Vec2f(static_cast<float>(o.x()), static_cast<float>(o.y()));
        }
      }
    });
  }
}

Eigen::Vector2d Rectification::RectifiedFromOriginal(Side s,
                                                     const Eigen::Vector2d& original_px) const {
  const Eigen::Vector2d xy = Camera(rig_, s).Unproject(original_px);
  const Eigen::Matrix3d& rot = s == Side::kLeft ? rect_from_left_ : rect_from_right_;
  const Eigen::Vector3d d = rot * Eigen::Vector3d(xy.x(), xy.y(), 1.0);
  return {f_ * d.x() / d.z() + cx(s), f_ * d.y() / d.z() + cy_};
}

Eigen::Vector2d Rectification::OriginalFromRectified(Side s,
                                                     const Eigen::Vector2d& rectified_px) const {
  const Eigen::Matrix3d& rot = s == Side::kLeft ? rect_from_left_ : rect_from_right_;
  const Eigen::Vector3d d_rect((rectified_px.x() - cx(s)) / f_, (rectified_px.y() - cy_) / f_, 1.0);
  const Eigen::Vector3d d = rot.transpose() * d_rect;
  if (d.z() <= 0) return {kNaN, kNaN};
  return Camera(rig_, s).Project(d);
}

Eigen::Vector2d Rectification::NormalizedFromRectified(Side s,
                                                       const Eigen::Vector2d& rectified_px) const {
  const Eigen::Matrix3d& rot = s == Side::kLeft ? rect_from_left_ : rect_from_right_;
  const Eigen::Vector3d d = rot.transpose() * Eigen::Vector3d((rectified_px.x() - cx(s)) / f_,
                                                              (rectified_px.y() - cy_) / f_, 1.0);
  return {d.x() / d.z(), d.y() / d.z()};
}

Eigen::Vector2d Rectification::ProjectRectified(Side s, const Eigen::Vector3d& p_in_left) const {
  Eigen::Vector3d p = rect_from_left_ * p_in_left;
  if (s == Side::kRight) p.x() -= baseline_mm_;
  return {f_ * p.x() / p.z() + cx(s), f_ * p.y() / p.z() + cy_};
}

cv::Mat Rectification::RectifyFloat(Side s, const cv::Mat& original) const {
  const CameraModel& cam = Camera(rig_, s);
  if (original.type() != CV_32FC1 || original.cols != cam.width || original.rows != cam.height) {
    throw Error(util::StrCat("RectifyFloat: expected a ", cam.width, "x", cam.height,
                             " CV_32F image, got ", original.cols, "x", original.rows, " of type ",
                             original.type()));
  }
  const cv::Mat& map = maps_[static_cast<int>(s)];
  cv::Mat out(map.size(), CV_32FC1);
  tbb::parallel_for(tbb::blocked_range<int>(0, map.rows), [&](const auto& rows) {
    for (int v = rows.begin(); v < rows.end(); ++v) {
      const auto* m = map.ptr<cv::Vec2f>(v);
      float* o = out.ptr<float>(v);
      for (int u = 0; u < map.cols; ++u) {
        o[u] = static_cast<float>(SampleBilinear(original, m[u][0], m[u][1]));
      }
    }
  });
  return out;
}

}  // namespace fringe::stereo
