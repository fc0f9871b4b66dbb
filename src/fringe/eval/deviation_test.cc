#include "fringe/eval/deviation.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fringe/util/error.h"

namespace fringe::eval {
namespace {

// Unit cube [0, 1]^3, triangles counter-clockwise seen from outside.
TriangleMesh Cube() {
  TriangleMesh m;
  auto* v = &m.vertices;
  auto* t = &m.triangles;
  for (int i = 0; i < 8; ++i) v->emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    t->push_back({q[0], q[1], q[2]});
    t->push_back({q[0], q[2], q[3]});
  }
  return m;
}

TEST(Deviation, DefaultOptionsPassCheck) { EXPECT_NO_THROW(DeviationOptions().Check()); }

TEST(Deviation, SignedDistancesToACube) {
  constexpr double kTol = 1e-12;
  const MeshDistance mesh(Cube());
  EXPECT_NEAR(mesh.SignedDistance({0.5, 0.5, 1.1}), 0.1, kTol);   // above the top face
  EXPECT_NEAR(mesh.SignedDistance({0.5, 0.5, 0.9}), -0.1, kTol);  // just inside
  EXPECT_NEAR(mesh.SignedDistance({0.3, -0.2, 0.4}), 0.2, kTol);  // in front of a face
  EXPECT_NEAR(mesh.SignedDistance({1.1, 0.5, 1.1}), 0.1 * std::sqrt(2.0), kTol);  // edge
  EXPECT_NEAR(mesh.SignedDistance({1.1, 1.1, 1.1}), 0.1 * std::sqrt(3.0), kTol);  // corner
  EXPECT_NEAR(mesh.SignedDistance({0.95, 0.95, 0.95}), -0.05, kTol);  // inside near a corner
  Eigen::Vector3d q;
  mesh.SignedDistance({0.2, 0.7, 3.0}, 1e30, &q);
  EXPECT_LT((q - Eigen::Vector3d(0.2, 0.7, 1.0)).norm(), kTol);
  EXPECT_TRUE(std::isnan(mesh.SignedDistance({0.5, 0.5, 5.0}, 1.0)));
}

TEST(Deviation, TrianglesWithoutAreaChangeNoDistance) {
  // Poisson's iso-surface can hold triangles of no area (a root clamped to a cell corner gives
  // two equal vertices). Added on the cube's top face they change nothing: every distance is
  // the plain cube's, also for points on their vertices (a 0/0 closest point on such a
  // triangle used to turn the query's best distance into NaN, after which any triangle won).
  constexpr double kTol = 1e-12;
  const MeshDistance plain(Cube());
  TriangleMesh m = Cube();
  const int first = static_cast<int>(m.vertices.size());
  m.vertices.emplace_back(0.5, 0.5, 1);   // first: twice the same point
  m.vertices.emplace_back(0.5, 0.5, 1);   // first + 1
  m.vertices.emplace_back(0.25, 0.5, 1);  // first + 2: on a line with first and first + 3
  m.vertices.emplace_back(0.75, 0.5, 1);  // first + 3
  m.triangles.push_back({first, first + 1, 4});
  m.triangles.push_back({first + 2, first, first + 3});
  m.triangles.push_back({first + 1, 7, first});
  const MeshDistance with_slivers(std::move(m));
  int compared = 0;
  for (double x = -0.2; x <= 1.2; x += 0.05) {
    for (double y = -0.2; y <= 1.2; y += 0.05) {
      for (double z : {0.9, 0.99, 1.0, 1.01, 1.3}) {
        const Eigen::Vector3d p(x, y, z);
        // Magnitudes only: the sign where the closest feature is a cube edge can differ between
        // runs even on the plain cube (not what this test is about).
        ASSERT_NEAR(std::abs(with_slivers.SignedDistance(p)), std::abs(plain.SignedDistance(p)),
                    kTol)
            << p.transpose();
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 1000);
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.5, 0.5, 1), Eigen::Vector3d(0.25, 0.5, 1)}) {
    EXPECT_NEAR(with_slivers.SignedDistance(p), 0, kTol) << p.transpose();
  }
}

TEST(Deviation, StatisticsAndColourMap) {
  const MeshDistance mesh(Cube());
  PointCloud cloud;
  // 100 points above the top face at heights -0.049 ... +0.050 mm, and one far away.
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

TEST(Deviation, BadMeshThrows) {
  EXPECT_THROW(MeshDistance(TriangleMesh{}), Error);
  TriangleMesh bad;
  bad.vertices = {Eigen::Vector3d::Zero()};
  bad.triangles = {{0, 1, 2}};
  EXPECT_THROW(MeshDistance(std::move(bad)), Error);
}

}  // namespace
}  // namespace fringe::eval
