#include "fringe/pipeline/report.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "fringe/sim/scene.h"
#include "fringe/util/error.h"
#include "fringe_test.h"

namespace fringe::pipeline {
namespace {

TEST(Report, RenderedBoxFillsItsSilhouette) {
  // A 20 mm cube seen along -x: its silhouette is a square of 20 mm in a frame of
  // 2.1 x the bounding radius (17.3 mm) on the shorter side.
  const TriangleMesh box =
      sim::MakeBoxMesh(Eigen::Vector3d(-10, -10, -10), Eigen::Vector3d(10, 10, 10));
  const cv::Mat img = RenderMesh(box, Eigen::Vector3d(-1, 0, 0), 200, 200);
  const double mm_per_px = 2.1 * std::sqrt(300.0) / 200;
  const double expected_px = std::pow(20 / mm_per_px, 2);
  EXPECT_NEAR(cv::countNonZero(img), expected_px, 0.05 * expected_px);
  EXPECT_EQ(img.at<uint8_t>(0, 0), 0);       // background
  EXPECT_GT(img.at<uint8_t>(100, 100), 40);  // the lit face
}

TEST(Report, RenderingsOfOneRendererDoNotDependOnTheThreadCount) {
  // The rows are cast in parallel; one thread and all threads give the same pictures, and the
  // renderer's pictures equal the free functions'.
  const TriangleMesh box =
      sim::MakeBoxMesh(Eigen::Vector3d(-10, -10, -10), Eigen::Vector3d(10, 12, 14));
  std::vector<double> values;
  for (const Eigen::Vector3d& v : box.vertices) values.push_back(v.z() / 14);
  const MeshRenderer renderer(box);
  const Eigen::Vector3d dir = Eigen::Vector3d(-1, 0.5, -0.7).normalized();
  const cv::Mat all = renderer.Render(dir, 160, 120);
  const cv::Mat all_coloured = renderer.RenderColoured(values, -1, 1, "mm", dir, 160, 120);
  cv::Mat one, one_coloured;
  tbb::task_arena(1).execute([&] {
    one = renderer.Render(dir, 160, 120);
    one_coloured = renderer.RenderColoured(values, -1, 1, "mm", dir, 160, 120);
  });
  EXPECT_GT(cv::countNonZero(all), 1000);
  EXPECT_EQ(cv::norm(all, one, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(all_coloured, one_coloured, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(all, RenderMesh(box, dir, 160, 120), cv::NORM_INF), 0);
}

TEST(Report, ColouredRenderingFollowsTheVertexValues) {
  // A square in the plane z = 0 seen from above, its value rising with x: the left of the
  // picture is blue (low), the right red (high); a colour bar is appended below.
  TriangleMesh square;
  square.vertices = {{-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0}};
  square.triangles = {{0, 1, 2}, {0, 2, 3}};
  const std::vector<double> values = {-1, 1, 1, -1};
  const cv::Mat img =
      RenderMeshColoured(square, values, -1, 1, "mm", Eigen::Vector3d(0, 0, -1), 200, 200);
  ASSERT_EQ(img.type(), CV_8UC3);
  EXPECT_GT(img.rows, 200);  // the bar
  const cv::Vec3b left = img.at<cv::Vec3b>(100, 40), right = img.at<cv::Vec3b>(100, 160);
  EXPECT_GT(left[0], left[2]);                             // blue-ish (BGR)
  EXPECT_GT(right[2], right[0]);                           // red-ish
  EXPECT_EQ(img.at<cv::Vec3b>(2, 2), cv::Vec3b(0, 0, 0));  // background
  EXPECT_THROW(RenderMeshColoured(square, {1, 2}, -1, 1, "mm", Eigen::Vector3d(0, 0, -1)), Error);
}

}  // namespace
}  // namespace fringe::pipeline
