// CGAL parts of the meshing (internal to the fusion module, kept in their own translation unit:
// CGAL's headers are slow to compile).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace fringe::fusion::internal {

struct IndexedMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;
};

// Closes every hole of an oriented triangle mesh by CGAL's hole triangulation
// (Polygon_mesh_processing::triangulate_hole, Liepa 2003: minimum-weight triangulation of each
// border cycle) after splitting pinched (non-manifold) vertices. Returns the number of holes
// closed; -1 when the triangles do not form an orientable polygon mesh.
int CloseHoles(IndexedMesh* mesh);

// CGAL's Poisson surface reconstruction (Kazhdan, Bolitho & Hoppe 2006 on a Delaunay
// refinement; CGAL::poisson_surface_reconstruction_delaunay) of oriented points with the given
// average spacing, meshed as a closed manifold (Manifold_tag). False when it fails.
bool CgalPoisson(const std::vector<Eigen::Vector3d>& points,
                 const std::vector<Eigen::Vector3d>& normals, double spacing_mm, IndexedMesh* out);

}  // namespace fringe::fusion::internal
