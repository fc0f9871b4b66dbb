#include "fringe/geometry/triangle_mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "fringe/util/error.h"

namespace fringe {
namespace {

// A unit right-angled tetrahedron, outward counter-clockwise faces.
TriangleMesh Tetrahedron() {
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

TEST(TriangleMesh, NormalsPointOutward) {
  TriangleMesh m = Tetrahedron();
  const Eigen::Vector3d inside(0.1, 0.1, 0.1);
  for (size_t i = 0; i < m.NumTriangles(); ++i) {
    EXPECT_NEAR(m.TriangleNormal(i).norm(), 1.0, 1e-12);
    EXPECT_GT(m.TriangleNormal(i).dot(m.vertices[m.triangles[i][0]] - inside), 0) << i;
  }
  m.ComputeVertexNormals();
  ASSERT_TRUE(m.has_normals());
  // The apex's neighbours are the faces x = 0, y = 0 (equal areas) and the slanted face.
  for (size_t v = 0; v < m.NumVertices(); ++v) {
    EXPECT_NEAR(m.normals[v].norm(), 1.0, 1e-12);
    EXPECT_GT(m.normals[v].dot(m.vertices[v] - inside), 0) << v;
  }
  // Vertex 0 touches the three axis faces of equal area: normal (-1, -1, -1) / sqrt 3.
  EXPECT_LT((m.normals[0] - Eigen::Vector3d(-1, -1, -1).normalized()).norm(), 1e-12);
}

TEST(TriangleMesh, AppendShiftsIndicesAndKeepsSharedAttributes) {
  TriangleMesh a = Tetrahedron(), b = Tetrahedron();
  a.ComputeVertexNormals();
  b.ComputeVertexNormals();
  b.colors.assign(b.NumVertices(), Color3u8{1, 2, 3});
  TriangleMesh all;
  all.Append(a);
  all.Append(b);
  EXPECT_EQ(all.NumVertices(), 8u);
  EXPECT_EQ(all.NumTriangles(), 8u);
  EXPECT_EQ(all.triangles[4], (TriangleMesh::Triangle{4, 6, 5}));
  EXPECT_EQ(all.normals.size(), 8u);
  EXPECT_FALSE(all.has_colors());  // a has none
  EXPECT_NO_THROW(all.Check("appended"));
}

TEST(TriangleMesh, TransformMovesVerticesAndRotatesNormals) {
  TriangleMesh m = Tetrahedron();
  m.ComputeVertexNormals();
  const Rigid3d b_from_a(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())),
      Eigen::Vector3d(10, -20, 30));
  TriangleMesh moved = m;
  moved.Transform(b_from_a);
  for (size_t v = 0; v < m.NumVertices(); ++v) {
    EXPECT_LT((moved.vertices[v] - b_from_a * m.vertices[v]).norm(), 1e-12);
    EXPECT_LT((moved.normals[v] - b_from_a.rotation() * m.normals[v]).norm(), 1e-12);
  }
  for (size_t i = 0; i < m.NumTriangles(); ++i) {
    EXPECT_LT((moved.TriangleNormal(i) - b_from_a.rotation() * m.TriangleNormal(i)).norm(), 1e-12);
  }
  Eigen::Vector3d lo, hi;
  m.Bounds(&lo, &hi);
  EXPECT_EQ(lo, Eigen::Vector3d::Zero());
  EXPECT_EQ(hi, Eigen::Vector3d::Ones());
}

TEST(TriangleMesh, CheckNamesContextAndProblem) {
  TriangleMesh m = Tetrahedron();
  EXPECT_NO_THROW(m.Check("tet"));
  m.triangles.push_back({0, 1, 4});
  try {
    m.Check("tet.ply");
    FAIL() << "index out of range accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("tet.ply: triangle 4 has vertex index 4"),
              std::string::npos)
        << e.what();
  }
  m = Tetrahedron();
  m.normals.resize(2);
  EXPECT_THROW(m.Check("tet"), Error);
  m = Tetrahedron();
  m.vertices[1].x() = std::nan("");
  EXPECT_THROW(m.Check("tet"), Error);
}

}  // namespace
}  // namespace fringe
