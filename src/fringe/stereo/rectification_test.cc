#include "fringe/stereo/rectification.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe::stereo {
namespace {

TEST(Rectification, DefaultOptionsPassCheck) { EXPECT_NO_THROW(RectificationOptions().Check()); }

TEST(Rectification, CorrespondingPointsShareTheRectifiedRow) {
  constexpr double kRowTolPx = 1e-6;
  constexpr double kRoundTripTolPx = 1e-6;
  const StereoRig rig = StereoRig::Reference();
  const Rectification rect(rig);
  EXPECT_NEAR(rect.baseline_mm(), rig.BaselineMm(), 1e-9);
  std::uniform_real_distribution<double> xy(-100, 100), z(420, 580);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d p(xy(util::GlobalRng()), xy(util::GlobalRng()), z(util::GlobalRng()));
    const Eigen::Vector2d l = rig.left.Project(p);
    const Eigen::Vector2d r = rig.right.Project(rig.right_from_left * p);
    const Eigen::Vector2d lr = rect.RectifiedFromOriginal(Side::kLeft, l);
    const Eigen::Vector2d rr = rect.RectifiedFromOriginal(Side::kRight, r);
    EXPECT_NEAR(lr.y(), rr.y(), kRowTolPx);
    EXPECT_LT((lr - rect.ProjectRectified(Side::kLeft, p)).norm(), kRowTolPx);
    EXPECT_LT((rr - rect.ProjectRectified(Side::kRight, p)).norm(), kRowTolPx);
    // Disparity formula of the header.
    const double z_rect = (rect.rect_from_left() * p).z();
    EXPECT_NEAR(lr.x() - rr.x(),
                rect.focal_px() * rect.baseline_mm() / z_rect + rect.cx(Side::kLeft) -
                    rect.cx(Side::kRight),
                1e-6);
    EXPECT_LT((rect.OriginalFromRectified(Side::kLeft, lr) - l).norm(), kRoundTripTolPx);
    EXPECT_LT((rect.OriginalFromRectified(Side::kRight, rr) - r).norm(), kRoundTripTolPx);
  }
}

TEST(Rectification, WholeOriginalImagesFitInTheRectifiedImages) {
  const StereoRig rig = StereoRig::Reference();
  const Rectification rect(rig);
  for (Side s : {Side::kLeft, Side::kRight}) {
    const CameraModel& cam = s == Side::kLeft ? rig.left : rig.right;
    const cv::Size size = rect.size(s);
    EXPECT_LT(size.width, 2 * cam.width);
    for (double u : {0.0, cam.width / 2.0, cam.width - 1.0}) {
      for (double v : {0.0, cam.height / 2.0, cam.height - 1.0}) {
        const Eigen::Vector2d q = rect.RectifiedFromOriginal(s, {u, v});
        EXPECT_GE(q.x(), -0.5);
        EXPECT_GE(q.y(), -0.5);
        EXPECT_LT(q.x(), size.width - 0.5);
        EXPECT_LT(q.y(), size.height - 0.5);
      }
    }
  }
}

TEST(Rectification, RectifyFloatResamplesSmoothImagesExactly) {
  // An image equal to its own column coordinate is resampled to the map's x coordinate.
  const StereoRig rig = StereoRig::Reference();
  const Rectification rect(rig);
  cv::Mat x_image(rig.right.height, rig.right.width, CV_32FC1);
  for (int r = 0; r < x_image.rows; ++r) {
    for (int c = 0; c < x_image.cols; ++c) x_image.at<float>(r, c) = static_cast<float>(c);
  }
  x_image.at<float>(500, 600) = std::numeric_limits<float>::quiet_NaN();
  const cv::Mat out = rect.RectifyFloat(Side::kRight, x_image);
  const cv::Mat& map = rect.OriginalFromRectifiedMap(Side::kRight);
  int finite = 0, nan_near_hole = 0;
  for (int r = 0; r < out.rows; ++r) {
    for (int c = 0; c < out.cols; ++c) {
      const float v = out.at<float>(r, c);
      const cv::Vec2f m = map.at<cv::Vec2f>(r, c);
      if (std::isfinite(v)) {
        ++finite;
        ASSERT_NEAR(v, m[0], 1e-3);
      } else if (std::abs(m[0] - 600) < 1 && std::abs(m[1] - 500) < 1) {
        ++nan_near_hole;
      }
    }
  }
  EXPECT_GT(finite, rig.right.width * rig.right.height * 9 / 10);
  EXPECT_GE(nan_near_hole, 1);
  EXPECT_THROW(rect.RectifyFloat(Side::kRight, cv::Mat(10, 10, CV_32FC1)), Error);
}

}  // namespace
}  // namespace fringe::stereo
