#include "fringe/fusion/mesh_cgal.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/manifoldness.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Random.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/poisson_surface_reconstruction.h>
#include <CGAL/property_map.h>

#include <iterator>
#include <utility>

namespace fringe::fusion::internal {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
using Mesh = CGAL::Surface_mesh<Point>;
namespace PMP = CGAL::Polygon_mesh_processing;

IndexedMesh FromSurfaceMesh(const Mesh& m) {
  IndexedMesh out;
  std::vector<int> index(m.number_of_vertices() + m.number_of_removed_vertices(), -1);
  for (const auto v : m.vertices()) {
    index[v.idx()] = static_cast<int>(out.vertices.size());
    const Point& p = m.point(v);
    out.vertices.emplace_back(p.x(), p.y(), p.z());
  }
  for (const auto f : m.faces()) {
    std::array<int, 3> t{};
    int k = 0;
    for (const auto v : CGAL::vertices_around_face(m.halfedge(f), m)) {
      if (k < 3) t[k] = index[v.idx()];
      ++k;
    }
    if (k == 3) out.triangles.push_back(t);
  }
  return out;
}

}  // namespace

int CloseHoles(IndexedMesh* mesh) {
  std::vector<Point> points;
  points.reserve(mesh->vertices.size());
  for (const auto& v : mesh->vertices) points.emplace_back(v.x(), v.y(), v.z());
  std::vector<std::vector<std::size_t>> polygons;
  polygons.reserve(mesh->triangles.size());
  for (const auto& t : mesh->triangles) {
    polygons.push_back({static_cast<std::size_t>(t[0]), static_cast<std::size_t>(t[1]),
                        static_cast<std::size_t>(t[2])});
  }
  if (!PMP::is_polygon_soup_a_polygon_mesh(polygons)) return -1;
  Mesh m;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, m);
  PMP::duplicate_non_manifold_vertices(m);
  std::vector<Mesh::Halfedge_index> cycles;
  PMP::extract_boundary_cycles(m, std::back_inserter(cycles));
  int closed = 0;
  for (const auto h : cycles) {
    std::vector<Mesh::Face_index> patch;
    PMP::triangulate_hole(m, h, std::back_inserter(patch));
    closed += patch.empty() ? 0 : 1;
  }
  *mesh = FromSurfaceMesh(m);
  return closed;
}

bool CgalPoisson(const std::vector<Eigen::Vector3d>& points,
                 const std::vector<Eigen::Vector3d>& normals, double spacing_mm, IndexedMesh* out) {
  std::vector<std::pair<Point, Vector>> oriented(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    oriented[i] = {Point(points[i].x(), points[i].y(), points[i].z()),
                   Vector(normals[i].x(), normals[i].y(), normals[i].z())};
  }
  // CGAL's default random generator (thread-local) is seeded from the clock; its mesher draws
  // from it, so the same cloud gave a different mesh from run to run. A fixed seed makes the
  // mesh a function of the input.
  CGAL::get_default_random() = CGAL::Random(0);
  Mesh m;
  const bool ok = CGAL::poisson_surface_reconstruction_delaunay(
      oriented.begin(), oriented.end(),
      CGAL::First_of_pair_property_map<std::pair<Point, Vector>>(),
      CGAL::Second_of_pair_property_map<std::pair<Point, Vector>>(), m, spacing_mm, 20.0, 30.0,
      0.375, CGAL::Manifold_tag());
  if (!ok || m.number_of_faces() == 0) return false;
  *out = FromSurfaceMesh(m);
  return true;
}

}  // namespace fringe::fusion::internal
