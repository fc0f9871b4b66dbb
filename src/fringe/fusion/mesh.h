// A triangle mesh of a fused cloud: screened Poisson surface reconstruction (Kazhdan & Hoppe,
// "Screened Poisson surface reconstruction", ACM TOG 2013) as implemented in Open3D
// (open3d::geometry::TriangleMesh::CreateFromPointCloudPoisson, Debian libopen3d-dev 0.16),
// not hand-written; CGAL's Poisson (libcgal-dev) is selectable (MeshLibrary) for small closed
// objects: on the demo part's fused cloud its Delaunay refinement ran out of memory.
//
// By default the mesh keeps only the measured surface: Poisson closes the surface everywhere,
// and vertices the data do not support are trimmed — those with a Poisson sampling density
// below the trim_density_quantile of all densities, or farther than trim_distance_factor *
// median point spacing from the nearest input point (the "bubbles" that close unscanned
// regions); the kept vertices are then projected onto the surface of their nearest points
// (project_to_points). `watertight` keeps the closed surface. `max_triangles` decimates by quadric
// error (Garland & Heckbert, Open3D's SimplifyQuadricDecimation) and reports the deviation the
// decimation adds (distances of the undecimated vertices to the decimated surface).
//
// Frames and units: those of the cloud (the world frame of a fused cloud), millimetres. The
// cloud needs normals (oriented outward, toward the sensors that measured it).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/triangle_mesh.h"

namespace fringe::fusion {

// The Poisson implementation: Open3D's screened Poisson on an adaptive octree (the default:
// faster and closer to the data on the demo part) or CGAL's Poisson on a
// Delaunay refinement (Kazhdan 2006, unscreened; meshed as a closed manifold).
enum class MeshLibrary { kOpen3d = 0, kCgal };
const char* ToString(MeshLibrary l);

struct MeshOptions {
  MeshLibrary library = MeshLibrary::kOpen3d;
  // Octree depth, [5, 14]; 0: from the cloud — the finest cell is cell_spacings median point
  // spacings exactly (Open3D's `width`: the cube is 2^depth such cells around the cloud's
  // centre, at least 1.1 x its largest side), and depth the smallest that allows it (Poisson's
  // cost grows ~4x per level on a surface: a fixed depth is either too coarse for a fine scan
  // or too slow for a coarse one). The wanted resolution may make the cell coarser: with
  // resolution_mm > 0 the cell is max(cell_spacings * spacing, resolution_mm) (detail finer than
  // the resolution is smoothed). 0: as fine as the points allow. A depth
  // outside [5, max_auto_depth] is clamped (the cube is then 1.1 x the largest side).
  // The cell is also at least as coarse as max_surface_cells allows (points * spacing^2 /
  // cell^2 finest cells on the surface, 0: no cap): Poisson's time follows the surface's cells,
  // so a dense cloud (a real stereo view at 0.03 mm spacing) gets as fine a mesh as a bounded
  // time allows instead of a fixed resolution, and the projection below restores the accuracy
  // a coarser cell smooths away.
  int poisson_depth = 0;
  double cell_spacings = 2;            // (0, 100]
  double resolution_mm = 0;            // >= 0
  int max_auto_depth = 12;             // [5, 14]
  int64_t max_surface_cells = 100000;  // 0: no cap, else >= 100
  // true: keep the closed Poisson surface, no trimming; holes left where Open3D's surface
  // leaves its bounding cube (an open scan: a plate seen from one side) are closed by CGAL's
  // hole triangulation.
  bool watertight = false;
  double trim_density_quantile = 0.02;  // [0, 1)
  // 2 spacings: inside the data a surface point is within ~0.7 spacing of a point, so a vertex
  // farther than 2 is Poisson's extrapolation past the data's border (on the demo scan 4 % of
  // the vertices at 4 spacings held 77 % of the vertices' squared error to the truth) or across
  // a gap wider than 4 spacings; both are left open rather than invented.
  double trim_distance_factor = 2;  // times the median point spacing, > 0
  // After Poisson (and trimming, before decimation) every vertex moves along the normal of the
  // weighted least-squares plane of its project_neighbours nearest input points onto the
  // weighted least-squares quadric height field over that plane (a moving-least-squares
  // projection, Alexa et al., "Computing and rendering point set surfaces", IEEE TVCG 2003,
  // one step, with the polynomial fit of Levin's MLS): Poisson's implicit function is smooth at
  // the scale of its cell and lies off the points where the surface curves within a cell or
  // ends (trimmed borders); the fit of the nearest points does not. The plane alone was
  // measured too: it lies inside curved parts (demo scan mesh -> truth 0.0733 mm, worse than no
  // projection's 0.0686; the quadric 0.0560 with the same trimming, docs/benchmarks.md).
  // Weights exp(-d^2 / h^2), h the k-th neighbour's distance; the quadric needs 10 neighbours
  // and a well-conditioned fit, else the plane is used. A vertex moves only where the plane is well
  // defined: the neighbours facing the vertex's side (normal . vertex normal > 0, so a thin wall's
  // back face is not taken), at least half of them, a spread across the plane at most
  // max_project_flatness of the spread along it (not a crease or a corner), and a move of at most
  // max_project_spacings point spacings (a larger one is a gap in the data, not smoothing).
  bool project_to_points = true;
  int project_neighbours = 24;         // [4, 256]
  double max_project_flatness = 0.25;  // smallest / middle eigenvalue of the spread, (0, 1]
  double max_project_spacings = 2;     // > 0
  int64_t max_triangles = 0;           // 0: no decimation; else >= 4
  // Poisson threads (OpenMP inside Open3D), 0: all, >= 0. 1 by default: OpenMP's spinning
  // threads slow down badly on a loaded machine and one thread is deterministic.
  int threads = 1;
  // Poisson in two pieces solved concurrently (mesh.cc, TwoPiecePoisson): 0 automatic — two
  // when the depth is automatic, the mesh is trimmed (not watertight), Open3D meshes, and the
  // surface holds at least 2 * min_cells_per_piece finest cells (estimated as points *
  // spacing^2 / cell^2: Poisson's cost follows the surface's cells, not the points; a property
  // of the data, not of the thread count: the mesh is the same on any number of threads); 1
  // never; 2 whenever the depth is automatic and the mesh trimmed. Each piece takes
  // piece_margin_cells cells of the other side's points.
  int poisson_pieces = 0;
  // 100,000: never with the default max_surface_cells (one problem of at most 100 k cells is
  // fast enough, and on a real capture 11 % of a seam stayed unjoined).
  int64_t min_cells_per_piece = 100000;
  // The two pieces' mesh is kept only when at most this fraction of the seam's vertices stayed
  // unjoined (else the one problem is solved: seam_refused).
  double max_seam_unmatched = 0.02;
  int piece_margin_cells = 16;

  void Check() const;
};

enum class MeshStatus {
  kOk = 0,
  kTooFewPoints,    // fewer than 10 points with finite positions and normals
  kMissingNormals,  // the cloud has no normals
  kFailed,          // the reconstruction produced no triangles
};
const char* ToString(MeshStatus s);

struct MeshSummary {
  MeshStatus status = MeshStatus::kOk;
  std::string message;
  int64_t input_points = 0;
  int64_t poisson_triangles = 0;  // before trimming and decimation
  int poisson_depth = 0;          // the depth used
  double cell_mm = 0;             // its finest cell: the cube's side / 2^depth
  int poisson_pieces = 1;         // 2: solved in two pieces joined on a grid plane
  double surface_cells = 0;       // points * spacing^2 / cell^2: the surface's finest cells
  // Two pieces: the second piece's vertices on the joining plane, and the vertices on it of
  // either piece without the other's on the same grid edge (one-cell cracks in the seam).
  int64_t seam_vertices = 0, seam_unmatched = 0;
  int64_t seam_holes_closed = 0;  // cracks (small boundary loops at the plane) fanned shut
  bool seam_refused = false;      // too many unjoined: solved as one problem instead
  double spacing_mm = 0;          // median nearest-neighbour distance of the cloud
  std::string library;            // "open3d" or "cgal"
  int64_t trimmed_vertices = 0;
  // project_to_points: vertices moved onto their points' plane, and the moves' RMS and max.
  int64_t projected_vertices = 0;
  double projection_rms_mm = 0, projection_max_mm = 0;
  int64_t closed_holes = 0;  // watertight: border cycles closed by CGAL's hole triangulation
  int64_t vertices = 0;
  int64_t triangles = 0;
  bool watertight = false;  // every edge shared by exactly two triangles, manifold vertices
  // Why a mesh is not watertight: edges of one triangle (holes, trimmed borders), edges of
  // more than two, vertices whose triangles do not form one fan.
  int64_t boundary_edges = 0, non_manifold_edges = 0, non_manifold_vertices = 0;
  bool decimated = false;
  double decimation_rms_mm = 0;  // undecimated vertices to the decimated surface
  double decimation_max_mm = 0;
  // Wall times: input and point spacing, Poisson, trimming (or hole closing) and decimation,
  // the projection onto the points, normals and the manifold checks; total.
  double spacing_s = 0, poisson_s = 0, trim_s = 0, project_s = 0, check_s = 0, total_s = 0;
  bool ok() const { return status == MeshStatus::kOk; }
  std::string BriefReport() const;
};
// As `fringe fuse --mesh --json` prints it (the "mesh" object).
nlohmann::json ToJson(const MeshSummary& s);

struct MeshResult {
  TriangleMesh mesh;  // vertices with unit normals; triangles counter-clockwise from outside
  MeshSummary summary;
};

// Bad options throw fringe::Error; bad data come back as a status.
MeshResult MeshPoisson(const PointCloud& cloud, const MeshOptions& options = {});

// `mesh` decimated to at most max_triangles triangles (>= 4, else fringe::Error) by
// meshoptimizer's edge collapses of least quadric error (Garland & Heckbert; meshopt_simplify,
// Debian libmeshoptimizer-dev; ~30x faster than Open3D's SimplifyQuadricDecimation, which
// MeshOptions::max_triangles uses: 0.1 s instead of 3.3 s for the full rig's 394 k triangles),
// vertex clustering (meshopt_simplifySloppy) for whatever collapses leave over the count;
// unreferenced vertices removed, vertex normals recomputed when it had them; `mesh` itself when
// it has no more triangles. The kept vertices are `mesh`'s own (not moved), in their order;
// source_vertex (optional) gets, per output vertex, its index in `mesh`. For a lighter copy to
// show (the report's 3D view), not for measuring.
TriangleMesh DecimateMesh(const TriangleMesh& mesh, int64_t max_triangles,
                          std::vector<int64_t>* source_vertex = nullptr);

// Writes the mesh by extension through io::WriteMesh: .ply (binary little-endian, with vertex
// normals) or .stl (binary). Atomic (temporary name, then rename). Throws fringe::Error for another
// extension or a failed write.
void WriteMeshFile(const std::filesystem::path& path, const MeshResult& mesh);

}  // namespace fringe::fusion
