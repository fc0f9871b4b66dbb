#include "fringe/sim/scene.h"

#include <gtest/gtest.h>

#include <fstream>

#include "fringe/io/mesh_io.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::sim {
namespace {

TEST(Scene, SphereMeshIsInscribedWithinSag) {
  const Sphere s{Eigen::Vector3d(1, 2, 3), 20.0};
  const double sag = 0.01;
  const TriangleMesh m = MakeSphereMesh(s, sag);
  for (const auto& v : m.vertices) EXPECT_NEAR((v - s.centre).norm(), s.radius_mm, 1e-9);
  for (size_t i = 0; i < m.triangles.size(); ++i) {
    const auto& t = m.triangles[i];
    const Eigen::Vector3d centroid = (m.vertices[t[0]] + m.vertices[t[1]] + m.vertices[t[2]]) / 3.0;
    EXPECT_LT(s.radius_mm - (centroid - s.centre).norm(), sag);
    // Outward orientation.
    EXPECT_GT(m.TriangleNormal(i).dot(centroid - s.centre), 0) << i;
  }
}

TEST(Scene, BoxAndCylinderAreOutwardOriented) {
  const TriangleMesh box = MakeBoxMesh(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 2, 3));
  const Eigen::Vector3d centre(0.5, 1, 1.5);
  for (size_t i = 0; i < box.triangles.size(); ++i) {
    const auto& t = box.triangles[i];
    const Eigen::Vector3d c = (box.vertices[t[0]] + box.vertices[t[1]] + box.vertices[t[2]]) / 3;
    EXPECT_GT(box.TriangleNormal(i).dot(c - centre), 0) << i;
  }
  const TriangleMesh cyl =
      MakeCylinderMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 5, 10, 0.01);
  for (size_t i = 0; i < cyl.triangles.size(); ++i) {
    const auto& t = cyl.triangles[i];
    const Eigen::Vector3d c = (cyl.vertices[t[0]] + cyl.vertices[t[1]] + cyl.vertices[t[2]]) / 3;
    EXPECT_GT(cyl.TriangleNormal(i).dot(c - Eigen::Vector3d(0, 0, 5)), 0) << i;
  }
}

TEST(Scene, MeshSceneFromFile) {
  test::TempDir dir;
  const TriangleMesh box = MakeBoxMesh(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 2, 3));
  io::WriteMesh(dir / "box.stl", box);
  const Scene scene = MakeMeshScene(dir / "box.stl");
  ASSERT_EQ(scene.objects().size(), 1u);
  EXPECT_EQ(scene.object(0).name, "box");
  EXPECT_EQ(scene.NumTriangles(), box.NumTriangles());
  EXPECT_EQ(scene.object(0).mesh.NumVertices(), 8u);  // STL corners welded again
  EXPECT_THROW(MakeMeshScene(dir / "missing.ply"), Error);
}

TEST(Scene, RejectsBadObjects) {
  Scene scene;
  SceneObject o;
  o.name = "empty";
  EXPECT_THROW(scene.AddObject(o), Error);
  o.mesh = MakeBoxMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  o.albedo = 1.5;
  EXPECT_THROW(scene.AddObject(o), Error);
  o.albedo = 0.5;
  o.mesh.triangles.push_back({0, 1, 99});
  EXPECT_THROW(scene.AddObject(o), Error);
}

TEST(Scene, ReadyMadeScenes) {
  for (const Scene& s : {MakeSphereScene(), MakeBallBarScene(), MakePlateScene(), MakePlaneScene(),
                         MakeVdiScene()}) {
    EXPECT_FALSE(s.objects().empty());
    EXPECT_GT(s.NumTriangles(), 0u);
  }
  const Scene bar = MakeBallBarScene(12.5, 200);
  ASSERT_NE(bar.FindObject("sphere_a"), nullptr);
  EXPECT_NEAR(
      (bar.FindObject("sphere_a")->sphere->centre - bar.FindObject("sphere_b")->sphere->centre)
          .norm(),
      200.0, 1e-12);
}

}  // namespace
}  // namespace fringe::sim
