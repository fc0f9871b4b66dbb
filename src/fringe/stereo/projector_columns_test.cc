#include "fringe/stereo/projector_columns.h"

#include <gtest/gtest.h>

#include <random>

#include "fringe/geometry/stereo_rig.h"
#include "fringe/util/error.h"

namespace fringe::stereo {
namespace {

// Points of the reference rig's working volume lit by its projector, with their true columns
// plus phase noise; `outlier_every`-th point moved off its projector ray (a false match).
struct Pairs {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> columns;
  std::vector<bool> outlier;
};

Pairs MakePairs(const StereoRig& rig, int n, double noise_px, int outlier_every,
                bool planar = false) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> lat(-90, 90), depth(430, 570), shift(5, 30);
  std::normal_distribution<double> noise(0, noise_px);
  Pairs p;
  while (static_cast<int>(p.points.size()) < n) {
    const Eigen::Vector3d x(lat(rng), lat(rng), planar ? 500 + 0.001 * lat(rng) : depth(rng));
    const Eigen::Vector3d in_projector = rig.projector_from_left * x;
    const Eigen::Vector2d px = rig.projector->Project(in_projector);
    if (!rig.projector->InImage(px)) continue;
    const bool bad = outlier_every > 0 && p.points.size() % outlier_every == 0;
    // A false match: the same phase, the point triangulated mm away across the projector rays.
    p.points.push_back(bad ? Eigen::Vector3d(x + Eigen::Vector3d(shift(rng), 0, 0)) : x);
    p.columns.push_back(px.x() + noise(rng));
    p.outlier.push_back(bad);
  }
  return p;
}

TEST(ProjectorColumns, FitRecoversTheColumnsAndRejectsFalseMatches) {
  constexpr double kNoisePx = 0.08;         // heterodyne phase noise, projector pixels
  constexpr double kMaxColumnErrPx = 0.01;  // fitted vs true column over the volume
  constexpr double kMaxErrorPx = 1.0;       // the matcher's projector tolerance
  const StereoRig rig = StereoRig::Reference();
  const Pairs p = MakePairs(rig, 20000, kNoisePx, 50);  // 2 % false matches
  const ProjectorColumnFit fit = FitProjectorColumns(p.points, p.columns);
  ASSERT_TRUE(fit.ok) << fit.message;
  EXPECT_NEAR(fit.rms_px, kNoisePx, 0.2 * kNoisePx);
  EXPECT_GT(fit.thickness, 0.1);
  // Model vs the true projector at fresh points (no noise, no outliers).
  const Pairs check = MakePairs(rig, 2000, 0, 0);
  double worst = 0;
  for (size_t i = 0; i < check.points.size(); ++i) {
    worst = std::max(worst, std::abs(fit.model.Column(check.points[i]) - check.columns[i]));
  }
  EXPECT_LT(worst, kMaxColumnErrPx);
  // The false matches are off by far more than the tolerance; the true ones within it.
  int false_kept = 0, true_lost = 0;
  for (size_t i = 0; i < p.points.size(); ++i) {
    const bool keep = std::abs(fit.model.Column(p.points[i]) - p.columns[i]) <= kMaxErrorPx;
    false_kept += p.outlier[i] && keep;
    true_lost += !p.outlier[i] && !keep;
  }
  EXPECT_EQ(false_kept, 0);
  EXPECT_EQ(true_lost, 0);
  // Behind the projector: no column.
  EXPECT_TRUE(std::isnan(
      fit.model.Column(rig.projector_from_left.Inverse() * Eigen::Vector3d(0, 0, -100))));
}

TEST(ProjectorColumns, RejectRemovesOnlyPointsOffTheirColumn) {
  const StereoRig rig = StereoRig::Reference();
  const Pairs p = MakePairs(rig, 5000, 0.05, 0);
  const ProjectorColumnFit fit = FitProjectorColumns(p.points, p.columns);
  ASSERT_TRUE(fit.ok) << fit.message;
  // A 3 x 2 grid: point 0 true, 1 false match, 2 invalid, 3 NaN phase, 4 and 5 true.
  OrganizedPointCloud cloud(3, 2);
  cv::Mat phase(2, 3, CV_32F, cv::Scalar(0));
  for (int i = 0; i < 6; ++i) {
    cloud.cloud.points[i] = p.points[i];
    cloud.valid[i] = i != 2;
    phase.at<float>(i / 3, i % 3) = static_cast<float>(p.columns[i]);
  }
  cloud.cloud.points[1].z() += 20;
  phase.at<float>(1, 0) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(RejectByProjectorColumns(fit.model, phase, 1.0, &cloud), 2);
  const std::vector<uint8_t> expected = {1, 0, 0, 0, 1, 1};
  EXPECT_EQ(cloud.valid, expected);
  std::vector<Eigen::Vector3d> pts;
  std::vector<double> cols;
  SampleProjectorColumns(cloud, phase, 1, &pts, &cols);
  EXPECT_EQ(pts.size(), 3u);
  EXPECT_THROW(RejectByProjectorColumns(fit.model, cv::Mat(2, 2, CV_32F), 1.0, &cloud), Error);
}

TEST(ProjectorColumns, RefusesPlanarPointsFewPointsAndPoorFits) {
  const StereoRig rig = StereoRig::Reference();
  const Pairs planar = MakePairs(rig, 5000, 0.05, 0, true);
  const ProjectorColumnFit flat = FitProjectorColumns(planar.points, planar.columns);
  EXPECT_FALSE(flat.ok);
  EXPECT_NE(flat.message.find("coplanar"), std::string::npos) << flat.message;
  const Pairs few = MakePairs(rig, 100, 0.05, 0);
  EXPECT_FALSE(FitProjectorColumns(few.points, few.columns).ok);
  // A distorted projector (k1 = -0.1: pixels of error at the edges) does not fit a pinhole.
  StereoRig distorted = rig;
  distorted.projector->k1 = -0.1;
  const Pairs bent = MakePairs(distorted, 5000, 0.05, 0);
  const ProjectorColumnFit poor = FitProjectorColumns(bent.points, bent.columns);
  EXPECT_FALSE(poor.ok) << poor.message;
  EXPECT_THROW(FitProjectorColumns(few.points, {1.0}), Error);
  ProjectorColumnFitOptions bad;
  bad.max_rms_px = 0;
  EXPECT_THROW(bad.Check(), Error);
}

}  // namespace
}  // namespace fringe::stereo
