#include "fringe/geometry/mesh_index.h"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <vector>

#include "fringe/util/error.h"

namespace fringe {
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

TEST(MeshIndex, SignedDistancesToACube) {
  constexpr double kTol = 1e-12;
  const MeshIndex mesh(Cube());
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

TEST(MeshIndex, TrianglesWithoutAreaChangeNoDistance) {
  // Poisson's iso-surface can hold triangles of no area (a root clamped to a cell corner gives
  // two equal vertices). Added on the cube's top face they change nothing: every distance is
  // the plain cube's, also for points on their vertices (a 0/0 closest point on such a
  // triangle used to turn the query's best distance into NaN, after which any triangle won).
  constexpr double kTol = 1e-12;
  const MeshIndex plain(Cube());
  TriangleMesh m = Cube();
  const int first = static_cast<int>(m.vertices.size());
  m.vertices.emplace_back(0.5, 0.5, 1);   // first: twice the same point
  m.vertices.emplace_back(0.5, 0.5, 1);   // first + 1
  m.vertices.emplace_back(0.25, 0.5, 1);  // first + 2: on a line with first and first + 3
  m.vertices.emplace_back(0.75, 0.5, 1);  // first + 3
  m.triangles.push_back({first, first + 1, 4});
  m.triangles.push_back({first + 2, first, first + 3});
  m.triangles.push_back({first + 1, 7, first});
  const MeshIndex with_slivers(std::move(m));
  int compared = 0;
  for (double x = -0.2; x <= 1.2; x += 0.05) {
    for (double y = -0.2; y <= 1.2; y += 0.05) {
      for (double z : {0.9, 0.99, 1.0, 1.01, 1.3}) {
        const Eigen::Vector3d p(x, y, z);
        ASSERT_NEAR(with_slivers.SignedDistance(p), plain.SignedDistance(p), kTol) << p.transpose();
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 1000);
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.5, 0.5, 1), Eigen::Vector3d(0.25, 0.5, 1)}) {
    EXPECT_NEAR(with_slivers.SignedDistance(p), 0, kTol) << p.transpose();
  }
}

TEST(MeshIndex, BadMeshThrows) {
  EXPECT_THROW(MeshIndex(TriangleMesh{}), Error);
  TriangleMesh bad;
  bad.vertices = {Eigen::Vector3d::Zero()};
  bad.triangles = {{0, 1, 2}};
  EXPECT_THROW(MeshIndex(std::move(bad)), Error);
}

// A cube moved by `offset`.
TriangleMesh CubeAt(const Eigen::Vector3d& offset) {
  TriangleMesh m = Cube();
  for (Eigen::Vector3d& v : m.vertices) v += offset;
  return m;
}

TEST(MeshIndex, RaysHitTheFirstSurfaceInDoublePrecision) {
  const MeshIndex index(Cube());
  // From an origin whose coordinates floats cannot hold: the hit is still on the ray and on the
  // face's plane to ~1e-12.
  const Eigen::Vector3d o(0.3000000001, 0.6000000003, 5.0000000007);
  const Eigen::Vector3d d = Eigen::Vector3d(0.01, -0.02, -1).normalized();
  const auto hit = index.Cast(o, d);
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->mesh, 0);
  EXPECT_NEAR(hit->point.z(), 1.0, 1e-12);
  EXPECT_LT((o + hit->t * d - hit->point).norm(), 1e-12);
  EXPECT_NEAR(hit->normal.z(), 1.0, 1e-12);  // the top face, counter-clockwise from outside
  EXPECT_TRUE(index.mesh(0).triangles[hit->triangle] == Cube().triangles[hit->triangle]);
  // Beyond t_min the far face is the first hit; away from the cube nothing is.
  const auto far = index.Cast(o, d, hit->t + 0.5);
  ASSERT_TRUE(far.has_value());
  EXPECT_NEAR(far->point.z(), 0.0, 1e-12);
  EXPECT_FALSE(index.Cast(o, Eigen::Vector3d::UnitZ()).has_value());
}

TEST(MeshIndex, SeveralMeshesAreOneSceneWithTheirOwnIndices) {
  std::vector<TriangleMesh> meshes = {Cube(), CubeAt({3, 0, 0})};
  const MeshIndex index(std::move(meshes));
  ASSERT_EQ(index.mesh_count(), 2);
  // A ray along +x from the left of both: the first cube, then (beyond it) the second.
  const Eigen::Vector3d o(-1, 0.5, 0.5);
  const auto first = index.Cast(o, Eigen::Vector3d::UnitX());
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->mesh, 0);
  EXPECT_NEAR(first->t, 1.0, 1e-12);
  const auto second = index.Cast(o, Eigen::Vector3d::UnitX(), 2.5);
  ASSERT_TRUE(second.has_value());
  EXPECT_EQ(second->mesh, 1);
  EXPECT_NEAR(second->t, 4.0, 1e-12);
  // Closest points come from whichever mesh is nearer, with each mesh's own signs.
  EXPECT_NEAR(index.SignedDistance({2.8, 0.5, 0.5}), 0.2, 1e-12);
  EXPECT_NEAR(index.SignedDistance({3.5, 0.5, 0.5}), -0.5, 1e-12);
  EXPECT_NEAR(index.SignedDistance({1.4, 0.5, 0.5}), 0.4, 1e-12);
  // Occlusion: the segment between the cubes is free, one through the second cube is not.
  EXPECT_FALSE(index.Occluded({1.2, 0.5, 0.5}, {2.8, 0.5, 0.5}));
  EXPECT_TRUE(index.Occluded({1.2, 0.5, 0.5}, {4.5, 0.5, 0.5}));
}

TEST(MeshIndex, BatchesEqualSingleQueries) {
  const MeshIndex index(std::vector<TriangleMesh>{Cube(), CubeAt({0, 0, -3})});
  const Eigen::Vector3d origin(0.5, 0.5, 4);
  std::vector<Eigen::Vector3d> dirs;
  // Off the faces' diagonals: a ray through an edge two triangles share may be given either.
  for (double x = -0.3; x <= 0.3; x += 0.05) {
    for (double y = -0.2877; y <= 0.3; y += 0.05) {
      dirs.push_back(Eigen::Vector3d(x, y, -1).normalized());
    }
  }
  std::vector<std::optional<MeshHit>> hits;
  index.CastBatch(origin, dirs, &hits);
  ASSERT_EQ(hits.size(), dirs.size());
  int hit_count = 0;
  for (size_t i = 0; i < dirs.size(); ++i) {
    const auto one = index.Cast(origin, dirs[i]);
    ASSERT_EQ(one.has_value(), hits[i].has_value()) << i;
    if (!one) continue;
    ++hit_count;
    EXPECT_EQ(one->mesh, hits[i]->mesh);
    EXPECT_EQ(one->triangle, hits[i]->triangle);
    EXPECT_EQ(one->t, hits[i]->t);
  }
  EXPECT_GT(hit_count, 0);
  EXPECT_LT(hit_count, static_cast<int>(dirs.size()));  // some rays miss the cubes
  // Shadow rays from below the lower cube, from beside it, towards a point above both.
  const std::vector<Eigen::Vector3d> from = {{0.5, 0.5, -5}, {5, 0.5, -5}};
  std::vector<uint8_t> occluded;
  index.OccludedBatch(from, {0.5, 0.5, 3}, &occluded);
  ASSERT_EQ(occluded.size(), 2u);
  EXPECT_EQ(occluded[0], 1);
  EXPECT_EQ(occluded[1], index.Occluded(from[1], {0.5, 0.5, 3}) ? 1 : 0);
}

TEST(MeshIndex, AttributesAreNotKept) {
  TriangleMesh m = Cube();
  m.ComputeVertexNormals();
  const MeshIndex index(std::move(m));
  EXPECT_TRUE(index.mesh(0).normals.empty());
  EXPECT_EQ(index.mesh(0).vertices.size(), 8u);
}

}  // namespace
}  // namespace fringe
