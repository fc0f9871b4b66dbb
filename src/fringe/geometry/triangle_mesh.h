// The one triangle mesh of fringe: the simulator's scenes, the reference surface of a deviation
// evaluation, truth/scene.ply and the meshes fusion produces are all this type; io reads and
// writes it (io/mesh_io.h: PLY, OBJ, STL).
//
// Storage is struct-of-arrays like PointCloud: `vertices` and `triangles` always, per-vertex
// `normals` and `colors` either empty (absent) or with one entry per vertex. Positions in
// millimetres, in the frame the owner names (a scene's mesh is in its world frame).
// Triangles are counter-clockwise seen from outside: TriangleNormal() points outward.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"

namespace fringe {

struct TriangleMesh {
  using Triangle = std::array<int32_t, 3>;  // vertex indices, counter-clockwise from outside

  std::vector<Eigen::Vector3d> vertices;
  std::vector<Triangle> triangles;
  std::vector<Eigen::Vector3d> normals;  // per vertex, unit length, or empty
  std::vector<Color3u8> colors;          // per vertex RGB, or empty

  size_t NumVertices() const { return vertices.size(); }
  size_t NumTriangles() const { return triangles.size(); }
  bool empty() const { return triangles.empty(); }
  bool has_normals() const { return !normals.empty(); }
  bool has_colors() const { return !colors.empty(); }

  // Appends `other`'s vertices and triangles (indices shifted). Per-vertex attributes are kept
  // only when both meshes have them (or this mesh is empty); otherwise they are dropped.
  void Append(const TriangleMesh& other);
  // Maps vertices (and rotates normals) from frame a to frame b.
  void Transform(const Rigid3d& b_from_a);
  // Unit normal of triangle i (right-handed order), zero for degenerate triangles.
  Eigen::Vector3d TriangleNormal(size_t i) const;
  // Area-weighted per-vertex normals from the triangles (replaces `normals`); vertices used by
  // no (non-degenerate) triangle get a zero normal.
  void ComputeVertexNormals();
  // Axis-aligned bounds of the vertices; both NaN when there are none.
  void Bounds(Eigen::Vector3d* min, Eigen::Vector3d* max) const;
  // Throws fringe::Error naming `context` (a file, an object) for a vertex index out of range, a
  // non-finite vertex or an attribute whose size is neither 0 nor NumVertices().
  void Check(const std::string& context) const;
};

}  // namespace fringe
