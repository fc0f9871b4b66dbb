#include "fringe/eval/deviation.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fringe/util/error.h"

namespace fringe::eval {
namespace {

// The unit square [0, 1]^2 at z = 1, facing +z.
TriangleMesh TopFace() {
  TriangleMesh m;
  m.vertices = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

TEST(Deviation, DefaultOptionsPassCheck) { EXPECT_NO_THROW(DeviationOptions().Check()); }

TEST(Deviation, StatisticsAndColourMap) {
  const MeshIndex mesh(TopFace());
  PointCloud cloud;
  // 100 points about the face at heights -0.049 ... +0.050 mm, and one far away.
  for (int i = 0; i < 100; ++i) {
    cloud.points.emplace_back(0.1 + 0.008 * i, 0.5, 1.0 + 0.001 * (i - 49));
  }
  cloud.points.emplace_back(0.5, 0.5, 9.0);
  std::vector<double> d;
  const DeviationStats s = DeviationFromMesh(cloud, mesh, {}, &d);
  EXPECT_EQ(s.points, 100);
  EXPECT_EQ(s.unmatched, 1);
  EXPECT_NEAR(s.mean_mm, 0.0005, 1e-9);
  EXPECT_NEAR(s.max_mm, 0.050, 1e-9);
  EXPECT_NEAR(s.p95_mm, 0.047, 1.5e-3);
  double sum_sq = 0;
  for (int i = 0; i < 100; ++i) sum_sq += std::pow(0.001 * (i - 49), 2);
  EXPECT_NEAR(s.rms_mm, std::sqrt(sum_sq / 100), 1e-9);
  EXPECT_TRUE(std::isnan(d[100]));

  const cv::Mat top = DeviationColorMapTopView(cloud, d, 0.05, 64);
  EXPECT_EQ(top.type(), CV_8UC3);
  std::vector<double> grid(6, 0.0);
  grid[0] = 0.05;
  grid[1] = -0.05;
  grid[2] = std::nan("");
  const cv::Mat img = DeviationColorMap(3, 2, grid, 0.05);
  EXPECT_EQ(img.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(img.at<cv::Vec3b>(0, 1), cv::Vec3b(255, 0, 0));
  EXPECT_EQ(img.at<cv::Vec3b>(1, 0), cv::Vec3b(0, 255, 0));
}

}  // namespace
}  // namespace fringe::eval
