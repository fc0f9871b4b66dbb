#include "fringe/fusion/mesh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_sort.h>

#include <meshoptimizer.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/TriangleMesh.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <tuple>

#include "fringe/fusion/mesh_cgal.h"
#include "fringe/geometry/mesh_index.h"
#include "fringe/geometry/point_index.h"
#include "fringe/io/mesh_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/timer.h"

namespace fringe::fusion {
namespace {

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

std::vector<TriangleMesh::Triangle> Triangles(const open3d::geometry::TriangleMesh& m) {
  std::vector<TriangleMesh::Triangle> t(m.triangles_.size());
  for (size_t i = 0; i < t.size(); ++i) {
    t[i] = {m.triangles_[i](0), m.triangles_[i](1), m.triangles_[i](2)};
  }
  return t;
}

// Edges of exactly one triangle (boundary) and of more than two (non-manifold), counted over the
// sorted list of all triangle edges.
std::pair<int64_t, int64_t> CountOddEdges(const open3d::geometry::TriangleMesh& m) {
  std::vector<std::pair<int, int>> edges;
  edges.reserve(3 * m.triangles_.size());
  for (const Eigen::Vector3i& t : m.triangles_) {
    for (int k = 0; k < 3; ++k) {
      const int a = t((k + 1) % 3), b = t((k + 2) % 3);
      edges.emplace_back(std::min(a, b), std::max(a, b));
    }
  }
  tbb::parallel_sort(edges.begin(), edges.end());
  int64_t boundary = 0, non_manifold = 0;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    boundary += j - i == 1;
    non_manifold += j - i > 2;
    i = j;
  }
  return {boundary, non_manifold};
}

// Quadric-error decimation to at most max_triangles (>= 1) triangles, unreferenced vertices
// removed.
std::shared_ptr<open3d::geometry::TriangleMesh> SimplifyQuadric(
    const open3d::geometry::TriangleMesh& mesh, int64_t max_triangles) {
  auto decimated =
      mesh.SimplifyQuadricDecimation(static_cast<int>(std::min<int64_t>(max_triangles, 2000000000)),
                                     std::numeric_limits<double>::infinity(), 1.0);
  decimated->RemoveUnreferencedVertices();
  return decimated;
}

MeshResult Fail(MeshResult r, MeshStatus status, std::string message) {
  r.summary.status = status;
  r.summary.message = std::move(message);
  return r;
}

// Open3D's screened Poisson: with width_mm > 0 the finest cell is width_mm (the cube: 2^depth
// such cells around the bounding box's centre, `depth` ignored), else the cube is scale * the
// box's largest side and `depth` its levels. threads 0: all.
std::tuple<std::shared_ptr<open3d::geometry::TriangleMesh>, std::vector<double>> Poisson(
    const open3d::geometry::PointCloud& pcd, int depth, double width_mm, float scale, int threads) {
  return open3d::geometry::TriangleMesh::CreateFromPointCloudPoisson(
      pcd, static_cast<size_t>(depth), static_cast<float>(width_mm), scale, false,
      threads == 0 ? -1 : threads);
}

// PoissonRecon's depth for a cube of `cells` finest cells along the largest side (its
// GetBoundingBoxXForm with `width`): the smallest with 2^depth >= cells.
int DepthForCells(double cells) {
  int depth = 0;
  while (depth < 30 && std::ldexp(1.0, depth) < cells) ++depth;
  return depth;
}

// Two pieces of one Poisson problem, solved concurrently (Open3D's Poisson is deterministic on
// one thread only, and one thread leaves a core idle on a large scan). Each piece holds the
// points on its side of a plane of the octree's grid plus a margin, and two anchor points just
// beyond the whole cloud's bounding box (far from every point: their little closed surfaces
// are trimmed with everything else far from the data), so that both pieces get the whole
// cloud's bounding box, hence the same cube and the same grid. A piece keeps the triangles on
// its side of the plane; marching cubes puts the vertices where the surface crosses grid
// edges, so the two pieces' vertices on the plane lie on the same edges and are joined.
// Where the pieces' solutions disagree on which edges the surface crosses (the implicit
// function near zero at a grid corner on the plane: 3 % of the seam on a simulated scan, 11 %
// on a real capture) their seam vertices stay unjoined (seam_unmatched) and a crack of a cell
// or two opens; CloseSeamCracks fans those shut. Far from the plane a piece's surface differs
// from the whole problem's by what the other piece's data change in the global solve
// (docs/benchmarks.md).
struct PiecewisePoisson {
  std::shared_ptr<open3d::geometry::TriangleMesh> mesh;
  std::vector<double> densities;
  int depth = 0;
  int64_t seam_vertices = 0, seam_unmatched = 0, seam_holes_closed = 0;
};

// Closes the cracks a two-piece join leaves. Poisson's surface is closed (but where it leaves
// its cube), so before trimming every boundary loop near the joining plane is a crack: where the
// pieces disagree on the surface's crossings of the plane (their contours on it differ over a
// cell or two), or where a leaf coarser than the finest cells straddles the plane (sparse data:
// each piece keeps its own triangles of it). Each loop of at most kMaxLoop edges whose
// vertices are all `near` is fanned with the orientation of its neighbours; loops that branch,
// do not close or whose diagonals exist already are left.
int64_t CloseSeamCracks(const std::vector<uint8_t>& near, open3d::geometry::TriangleMesh* m) {
  constexpr size_t kMaxLoop = 24;
  // Directed edges of the triangles with both ends near the plane.
  std::vector<std::pair<int, int>> edges;
  for (const Eigen::Vector3i& t : m->triangles_) {
    for (int k = 0; k < 3; ++k) {
      const int a = t(k), b = t((k + 1) % 3);
      if (near[static_cast<size_t>(a)] && near[static_cast<size_t>(b)]) edges.emplace_back(a, b);
    }
  }
  std::sort(edges.begin(), edges.end());
  const auto has = [&](int a, int b) {
    return std::binary_search(edges.begin(), edges.end(), std::make_pair(a, b));
  };
  // Boundary half-edges: no triangle on the other side. The loop follows a -> b -> ...
  std::map<int, std::vector<int>> next;
  for (size_t i = 0; i < edges.size(); ++i) {
    const auto [a, b] = edges[i];
    const bool twice =
        (i > 0 && edges[i - 1] == edges[i]) || (i + 1 < edges.size() && edges[i + 1] == edges[i]);
    if (!twice && !has(b, a)) next[a].push_back(b);
  }
  std::vector<uint8_t> used(m->vertices_.size(), 0);
  int64_t closed = 0;
  for (const auto& [start, outs] : next) {
    if (used[static_cast<size_t>(start)] || outs.size() != 1) continue;
    std::vector<int> loop = {start};
    bool ok = false;
    while (loop.size() <= kMaxLoop) {
      const auto it = next.find(loop.back());
      if (it == next.end() || it->second.size() != 1 || used[static_cast<size_t>(it->first)]) break;
      const int b = it->second[0];
      if (b == start) {
        ok = loop.size() >= 3;
        break;
      }
      if (std::find(loop.begin(), loop.end(), b) != loop.end()) break;
      loop.push_back(b);
    }
    if (!ok) continue;
    // Fan from loop[0] over the reversed loop: triangles (v0, v_k, v_{k-1}), whose edges
    // v_k -> v_{k-1} are the reverses of the boundary half-edges; diagonals v0 - v_k new.
    bool fresh = true;
    for (size_t k = 2; k + 1 < loop.size() && fresh; ++k) {
      fresh = !has(loop[0], loop[k]) && !has(loop[k], loop[0]);
    }
    if (!fresh) continue;
    for (int v : loop) used[static_cast<size_t>(v)] = 1;
    for (size_t k = loop.size() - 1; k >= 2; --k) {
      m->triangles_.emplace_back(loop[0], loop[k], loop[k - 1]);
    }
    ++closed;
  }
  return closed;
}

PiecewisePoisson TwoPiecePoisson(const open3d::geometry::PointCloud& pcd, double width_mm,
                                 float scale, int threads, int margin_cells) {
  const Eigen::Vector3d lo0 = pcd.GetMinBound(), hi0 = pcd.GetMaxBound();
  int axis = 0;
  (hi0 - lo0).maxCoeff(&axis);
  // Anchors: a few cells and 1 % of the extent beyond the box's corners.
  const double delta = std::max(8 * width_mm, 0.01 * (hi0 - lo0).maxCoeff());
  const Eigen::Vector3d lo = lo0.array() - delta, hi = hi0.array() + delta;
  // PoissonRecon's cube for `width` (GetBoundingBoxXForm): 2^depth cells, the smallest depth
  // with 2^depth >= scale * largest side / width, centred on the box.
  const int depth = DepthForCells(scale * (hi - lo).maxCoeff() / width_mm);
  const double side = std::ldexp(width_mm, depth);
  const Eigen::Vector3d cube_min = 0.5 * (lo + hi).array() - 0.5 * side;
  // The plane: the grid plane at an odd cell index (not a face of the next coarser level's
  // cells) nearest the points' median along the axis (equal work). On even indices the two
  // pieces disagree far more often about the crossings: on the full-rig demo scan 69 of 634 seam
  // vertices unjoined on a face of level-5 cells, 19 of 610 on an even one, 0 of 587 on the odd
  // one beside it (docs/benchmarks.md).
  std::vector<double> along(pcd.points_.size());
  for (size_t i = 0; i < along.size(); ++i) along[i] = pcd.points_[i](axis);
  std::nth_element(along.begin(), along.begin() + static_cast<std::ptrdiff_t>(along.size() / 2),
                   along.end());
  const double plane =
      cube_min(axis) +
      width_mm * (2 * std::floor((along[along.size() / 2] - cube_min(axis)) / (2 * width_mm)) + 1);
  const double margin = margin_cells * width_mm;
  open3d::geometry::PointCloud pieces[2];
  for (size_t i = 0; i < pcd.points_.size(); ++i) {
    const double x = pcd.points_[i](axis);
    for (int k = 0; k < 2; ++k) {
      if (k == 0 ? x < plane + margin : x > plane - margin) {
        pieces[k].points_.push_back(pcd.points_[i]);
        pieces[k].normals_.push_back(pcd.normals_[i]);
      }
    }
  }
  for (auto& piece : pieces) {
    for (const Eigen::Vector3d& anchor : {lo, hi}) {
      piece.points_.push_back(anchor);
      piece.normals_.push_back(Eigen::Vector3d::UnitZ());
    }
  }
  std::tuple<std::shared_ptr<open3d::geometry::TriangleMesh>, std::vector<double>> solved[2];
  tbb::parallel_invoke([&] { solved[0] = Poisson(pieces[0], 0, width_mm, scale, threads); },
                       [&] { solved[1] = Poisson(pieces[1], 0, width_mm, scale, threads); });

  // Join: piece 0 keeps the triangles up to the plane, piece 1 those beyond (a triangle lies in
  // one cell; one flat on the plane goes to piece 0). Piece 1's vertices on the plane take
  // piece 0's vertex on the same grid edge.
  const double eps = 1e-3 * width_mm;
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  // A vertex on the plane lies on a grid edge along u or v: the edge's key is its integral
  // coordinate and the cell index of the fractional one (both integral: a grid corner).
  const auto edge_key = [&](const Eigen::Vector3d& p, std::array<int64_t, 3>* key) {
    const double gu = (p(u) - cube_min(u)) / width_mm, gv = (p(v) - cube_min(v)) / width_mm;
    const bool iu = std::abs(gu - std::round(gu)) < 1e-3, iv = std::abs(gv - std::round(gv)) < 1e-3;
    if (!iu && !iv) return false;
    *key = {static_cast<int64_t>(iu ? std::round(gu) : std::floor(gu)),
            static_cast<int64_t>(iv ? std::round(gv) : std::floor(gv)), iu + 2 * iv};
    return true;
  };
  PiecewisePoisson out;
  out.depth = depth;
  out.mesh = std::make_shared<open3d::geometry::TriangleMesh>();
  std::map<std::array<int64_t, 3>, int> seam;  // piece 0's vertices on the plane
  for (int k = 0; k < 2; ++k) {
    const auto& [mesh, densities] = solved[k];
    std::vector<int> index(mesh->vertices_.size(), -1);
    for (const Eigen::Vector3i& t : mesh->triangles_) {
      const double c = (mesh->vertices_[t(0)](axis) + mesh->vertices_[t(1)](axis) +
                        mesh->vertices_[t(2)](axis)) /
                       3;
      if ((k == 0) != (c <= plane + eps)) continue;
      Eigen::Vector3i joined;
      for (int j = 0; j < 3; ++j) {
        int& to = index[static_cast<size_t>(t(j))];
        if (to < 0) {
          const Eigen::Vector3d& p = mesh->vertices_[static_cast<size_t>(t(j))];
          std::array<int64_t, 3> key;
          const bool on_plane = std::abs(p(axis) - plane) <= eps && edge_key(p, &key);
          if (on_plane && k == 1) {
            ++out.seam_vertices;
            const auto it = seam.find(key);
            if (it != seam.end() &&
                (out.mesh->vertices_[static_cast<size_t>(it->second)] - p).norm() <
                    0.5 * width_mm) {
              to = it->second;
              seam.erase(it);  // joined
            } else {
              ++out.seam_unmatched;
            }
          }
          if (to < 0) {
            to = static_cast<int>(out.mesh->vertices_.size());
            out.mesh->vertices_.push_back(p);
            out.densities.push_back(densities[static_cast<size_t>(t(j))]);
            if (on_plane && k == 0) seam.emplace(key, to);
          }
        }
        joined(j) = to;
      }
      out.mesh->triangles_.push_back(joined);
    }
  }
  out.seam_unmatched += static_cast<int64_t>(seam.size());  // the first piece's, not joined
  // Near: within two cells of the finest level (a straddling coarse leaf reaches farther; its
  // cracks are left).
  std::vector<uint8_t> near(out.mesh->vertices_.size());
  for (size_t i = 0; i < near.size(); ++i) {
    near[i] = std::abs(out.mesh->vertices_[i](axis) - plane) <= 2 * width_mm;
  }
  out.seam_holes_closed = CloseSeamCracks(near, out.mesh.get());
  return out;
}

struct Projection {
  int64_t moved = 0;
  double rms_mm = 0, max_mm = 0;
};

// MeshOptions::project_to_points: each vertex onto the weighted least-squares plane of its
// nearest input points (see the header). Needs the mesh's vertex normals (to choose the
// neighbours on the vertex's side); every vertex is computed from the unprojected mesh and the
// points only, so the result does not depend on the thread count.
Projection ProjectOntoPoints(const PointIndex& tree, const std::vector<Eigen::Vector3d>& normals,
                             double spacing_mm, const MeshOptions& o,
                             open3d::geometry::TriangleMesh* mesh) {
  const size_t k = static_cast<size_t>(o.project_neighbours);
  const double max_move_mm = o.max_project_spacings * spacing_mm;
  std::vector<Eigen::Vector3d> moved = mesh->vertices_;
  std::vector<double> move_mm(moved.size(), 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, moved.size()), [&](const auto& range) {
    std::vector<size_t> idx;
    std::vector<double> d2;
    for (size_t v = range.begin(); v != range.end(); ++v) {
      const Eigen::Vector3d& p = mesh->vertices_[v];
      const Eigen::Vector3d& n = mesh->vertex_normals_[v];
      const size_t found = tree.Nearest(p, k, &idx, &d2);
      if (found < 4) continue;
      const double h2 = std::max(d2[found - 1], 1e-18);
      double w_sum = 0;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      size_t used = 0;
      for (size_t j = 0; j < found; ++j) {
        if (normals[idx[j]].dot(n) <= 0) continue;  // the other side of a thin wall
        const double w = std::exp(-d2[j] / h2);
        w_sum += w;
        mean += w * tree.point(idx[j]);
        ++used;
      }
      if (2 * used < found || used < 4) continue;
      mean /= w_sum;
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (size_t j = 0; j < found; ++j) {
        if (normals[idx[j]].dot(n) <= 0) continue;
        const Eigen::Vector3d q = tree.point(idx[j]) - mean;
        cov += std::exp(-d2[j] / h2) * q * q.transpose();
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
      const Eigen::Vector3d ev = eig.eigenvalues();  // ascending
      if (!(ev(1) > 0) || ev(0) > o.max_project_flatness * ev(1)) continue;
      const Eigen::Vector3d plane_n = eig.eigenvectors().col(0);
      const Eigen::Vector3d e1 = eig.eigenvectors().col(2), e2 = eig.eigenvectors().col(1);
      // The height over the plane as a weighted quadric in the plane's coordinates centred on
      // the vertex's foot: a plane alone lies inside a curved surface by ~ h^2 * curvature / 2
      // (0.05 mm for a 1 mm neighbourhood on a 10 mm radius), the quadric does not.
      Eigen::Matrix<double, 6, 6> ata = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> atb = Eigen::Matrix<double, 6, 1>::Zero();
      for (size_t j = 0; j < found; ++j) {
        if (normals[idx[j]].dot(n) <= 0) continue;
        const Eigen::Vector3d q = tree.point(idx[j]) - p;
        const double u = q.dot(e1), w = q.dot(e2);
        Eigen::Matrix<double, 6, 1> row;
        row << 1, u, w, u * u, u * w, w * w;
        const double wt = std::exp(-d2[j] / h2);
        ata.noalias() += wt * row * row.transpose();
        atb.noalias() += wt * row * (tree.point(idx[j]) - mean).dot(plane_n);
      }
      double height = 0;  // of the surface over the plane at the vertex's foot
      if (used >= 10) {
        const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(ata);
        if (ldlt.info() == Eigen::Success && ldlt.rcond() > 1e-10) {
          const double a = ldlt.solve(atb)(0);
          if (std::isfinite(a) && std::abs(a) <= max_move_mm) height = a;
        }
      }
      const double off = plane_n.dot(p - mean) - height;
      if (!(std::abs(off) <= max_move_mm)) continue;
      moved[v] = p - off * plane_n;
      move_mm[v] = std::abs(off);
    }
  });
  Projection out;
  double sum_sq = 0;
  for (double m : move_mm) {
    out.moved += m > 0;
    sum_sq += m * m;
    out.max_mm = std::max(out.max_mm, m);
  }
  out.rms_mm = std::sqrt(sum_sq / static_cast<double>(std::max<size_t>(move_mm.size(), 1)));
  mesh->vertices_ = std::move(moved);
  return out;
}

}  // namespace

void MeshOptions::Check() const {
  constexpr const char* kName = "MeshOptions";
  util::CheckOption(poisson_depth == 0 || (poisson_depth >= 5 && poisson_depth <= 14), kName,
                    "poisson_depth", poisson_depth, "must be 0 (from the cloud) or in [5, 14]");
  util::CheckOption(cell_spacings > 0 && cell_spacings <= 100, kName, "cell_spacings",
                    cell_spacings, "must be in (0, 100]");
  util::CheckOption(resolution_mm >= 0 && std::isfinite(resolution_mm), kName, "resolution_mm",
                    resolution_mm, "must be finite and >= 0");
  util::CheckOption(max_auto_depth >= 5 && max_auto_depth <= 14, kName, "max_auto_depth",
                    max_auto_depth, "must be in [5, 14]");
  util::CheckOption(max_surface_cells == 0 || max_surface_cells >= 100, kName, "max_surface_cells",
                    max_surface_cells, "must be 0 (no cap) or >= 100");
  util::CheckOption(project_neighbours >= 4 && project_neighbours <= 256, kName,
                    "project_neighbours", project_neighbours, "must be in [4, 256]");
  util::CheckOption(max_project_flatness > 0 && max_project_flatness <= 1, kName,
                    "max_project_flatness", max_project_flatness, "must be in (0, 1]");
  util::CheckOption(max_project_spacings > 0 && std::isfinite(max_project_spacings), kName,
                    "max_project_spacings", max_project_spacings, "must be finite and > 0");
  util::CheckOption(trim_density_quantile >= 0 && trim_density_quantile < 1, kName,
                    "trim_density_quantile", trim_density_quantile, "must be in [0, 1)");
  util::CheckOption(trim_distance_factor > 0, kName, "trim_distance_factor", trim_distance_factor,
                    "must be > 0");
  util::CheckOption(max_triangles == 0 || max_triangles >= 4, kName, "max_triangles", max_triangles,
                    "must be 0 (no decimation) or >= 4");
  util::CheckOption(threads >= 0, kName, "threads", threads, "must be >= 0");
  util::CheckOption(poisson_pieces >= 0 && poisson_pieces <= 2, kName, "poisson_pieces",
                    poisson_pieces, "must be 0 (automatic), 1 or 2");
  util::CheckOption(min_cells_per_piece >= 1, kName, "min_cells_per_piece", min_cells_per_piece,
                    "must be >= 1");
  util::CheckOption(max_seam_unmatched >= 0 && max_seam_unmatched <= 1, kName, "max_seam_unmatched",
                    max_seam_unmatched, "must be in [0, 1]");
  util::CheckOption(piece_margin_cells >= 2 && piece_margin_cells <= 1000, kName,
                    "piece_margin_cells", piece_margin_cells, "must be in [2, 1000]");
}

const char* ToString(MeshLibrary l) {
  switch (l) {
    case MeshLibrary::kOpen3d:
      return "open3d";
    case MeshLibrary::kCgal:
      return "cgal";
  }
  return "?";
}

const char* ToString(MeshStatus s) {
  switch (s) {
    case MeshStatus::kOk:
      return "ok";
    case MeshStatus::kTooFewPoints:
      return "too few points";
    case MeshStatus::kMissingNormals:
      return "missing normals";
    case MeshStatus::kFailed:
      return "failed";
  }
  return "?";
}

std::string MeshSummary::BriefReport() const {
  std::string s = util::StrCat(
      "mesh: ", ToString(status), ", ", input_points, " points (spacing ", spacing_mm,
      " mm) -> depth ", poisson_depth, " (", cell_mm, " mm cells): ", poisson_triangles,
      " Poisson triangles, ", trimmed_vertices, " vertices trimmed, ", projected_vertices,
      " projected onto the points (RMS ", projection_rms_mm, " mm) -> ", vertices, " vertices, ",
      triangles, " triangles, ",
      watertight ? std::string("watertight")
                 : util::StrCat("not watertight (", boundary_edges, " boundary edges, ",
                                non_manifold_edges, " non-manifold edges, ", non_manifold_vertices,
                                " non-manifold vertices)"));
  if (seam_refused) {
    s += util::StrCat(", two Poisson pieces refused (", seam_unmatched, " of ", seam_vertices,
                      " seam vertices not joined): one problem");
  }
  if (poisson_pieces > 1) {
    s += util::StrCat(", ", poisson_pieces, " Poisson pieces (", seam_vertices, " seam vertices, ",
                      seam_unmatched, " not joined, ", seam_holes_closed, " cracks closed)");
  }
  if (decimated) {
    s += util::StrCat(", decimation deviation RMS ", decimation_rms_mm, " mm (max ",
                      decimation_max_mm, " mm)");
  }
  s += util::StrCat(", Poisson ", poisson_s, " s, total ", total_s, " s");
  if (!message.empty()) s += ": " + message;
  return s;
}

nlohmann::json ToJson(const MeshSummary& s) {
  return {{"status", ToString(s.status)},
          {"message", s.message},
          {"input_points", s.input_points},
          {"poisson_triangles", s.poisson_triangles},
          {"library", s.library},
          {"poisson_depth", s.poisson_depth},
          {"cell_mm", s.cell_mm},
          {"poisson_pieces", s.poisson_pieces},
          {"surface_cells", s.surface_cells},
          {"seam_vertices", s.seam_vertices},
          {"seam_unmatched", s.seam_unmatched},
          {"seam_holes_closed", s.seam_holes_closed},
          {"seam_refused", s.seam_refused},
          {"closed_holes", s.closed_holes},
          {"spacing_mm", s.spacing_mm},
          {"trimmed_vertices", s.trimmed_vertices},
          {"projected_vertices", s.projected_vertices},
          {"projection_rms_mm", s.projection_rms_mm},
          {"projection_max_mm", s.projection_max_mm},
          {"vertices", s.vertices},
          {"triangles", s.triangles},
          {"watertight", s.watertight},
          {"boundary_edges", s.boundary_edges},
          {"non_manifold_edges", s.non_manifold_edges},
          {"non_manifold_vertices", s.non_manifold_vertices},
          {"decimated", s.decimated},
          {"decimation_rms_mm", s.decimation_rms_mm},
          {"decimation_max_mm", s.decimation_max_mm},
          {"spacing_s", s.spacing_s},
          {"poisson_s", s.poisson_s},
          {"trim_s", s.trim_s},
          {"project_s", s.project_s},
          {"check_s", s.check_s},
          {"total_s", s.total_s}};
}

MeshResult MeshPoisson(const PointCloud& cloud, const MeshOptions& options) {
  options.Check();
  cloud.CheckConsistent();
  util::Timer total;
  MeshResult result;
  MeshSummary& s = result.summary;
  if (!cloud.has_normals() && !cloud.empty()) {
    return Fail(std::move(result), MeshStatus::kMissingNormals,
                "the cloud has no normals (Poisson needs oriented normals)");
  }
  open3d::geometry::PointCloud pcd;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.points[i].allFinite() || !cloud.normals[i].allFinite()) continue;
    pcd.points_.push_back(cloud.points[i]);
    pcd.normals_.push_back(cloud.normals[i]);
  }
  s.input_points = static_cast<int64_t>(pcd.points_.size());
  if (pcd.points_.size() < 10) {
    return Fail(std::move(result), MeshStatus::kTooFewPoints,
                util::StrCat(pcd.points_.size(), " points with position and normal"));
  }

  // Median point spacing from every 8th point's nearest neighbour (the tree also serves the
  // trimming below).
  const PointIndex tree(pcd.points_);
  {
    std::vector<double> nn((pcd.points_.size() + 7) / 8);
    tbb::parallel_for(size_t{0}, nn.size(), [&](size_t k) {
      std::vector<size_t> idx;
      std::vector<double> d2;
      nn[k] = tree.Nearest(pcd.points_[8 * k], 2, &idx, &d2) == 2 ? std::sqrt(d2[1]) : 0;
    });
    s.spacing_mm = Quantile(nn, 0.5);
  }
  constexpr double kScale = 1.1;  // Poisson's cube: at least the bounding box's largest side * 1.1
  s.poisson_depth = options.poisson_depth;
  const double extent_mm = (pcd.GetMaxBound() - pcd.GetMinBound()).maxCoeff();
  const double cube_mm = kScale * extent_mm;
  // Automatic: the finest cell is the wanted one exactly (Open3D's `width`: the cube grows to
  // 2^depth cells of that size around the bounding box's centre), not the next power-of-two
  // fraction of the box below it, which is up to 2x finer and ~4x slower for detail nobody asked
  // for. Outside [5, max_auto_depth] levels the depth is clamped and the cube is kScale * extent.
  double width_mm = 0;
  if (s.poisson_depth == 0) {
    // At most max_surface_cells: points * spacing^2 / cell^2 <= max.
    const double capped_mm =
        options.max_surface_cells > 0
            ? s.spacing_mm * std::sqrt(static_cast<double>(s.input_points) /
                                       static_cast<double>(options.max_surface_cells))
            : 0;
    const double cell_mm =
        std::max({options.cell_spacings * s.spacing_mm, options.resolution_mm, capped_mm});
    const int depth = DepthForCells(cube_mm / std::max(cell_mm, 1e-9));
    if (depth < 5 || depth > options.max_auto_depth) {
      s.poisson_depth = std::clamp(depth, 5, options.max_auto_depth);
    } else {
      s.poisson_depth = depth;
      width_mm = cell_mm;
    }
  }
  s.cell_mm = width_mm > 0 ? width_mm : cube_mm / std::pow(2.0, s.poisson_depth);
  s.surface_cells = static_cast<double>(s.input_points) * s.spacing_mm * s.spacing_mm /
                    std::max(s.cell_mm * s.cell_mm, 1e-18);
  s.library = ToString(options.library);
  s.spacing_s = total.ElapsedSeconds();
  util::Timer timer;
  std::shared_ptr<open3d::geometry::TriangleMesh> mesh;
  std::vector<double> densities;  // Open3D only
  const bool two_pieces =
      options.library == MeshLibrary::kOpen3d && width_mm > 0 && !options.watertight &&
      (options.poisson_pieces == 2 ||
       (options.poisson_pieces == 0 &&
        s.surface_cells >= 2.0 * static_cast<double>(options.min_cells_per_piece)));
  bool one_piece = !two_pieces;
  if (two_pieces) {
    PiecewisePoisson pp = TwoPiecePoisson(pcd, width_mm, static_cast<float>(kScale),
                                          options.threads, options.piece_margin_cells);
    s.seam_vertices = pp.seam_vertices;
    s.seam_unmatched = pp.seam_unmatched;
    s.seam_holes_closed = pp.seam_holes_closed;
    // A seam the pieces disagree on too often (noisy or sparse data near the plane) is not
    // kept: the one problem is solved instead (the seam's figures stay in the summary).
    if (static_cast<double>(pp.seam_unmatched) >
        options.max_seam_unmatched * static_cast<double>(pp.seam_vertices)) {
      s.seam_refused = true;
      one_piece = true;
    } else {
      mesh = std::move(pp.mesh);
      densities = std::move(pp.densities);
      s.poisson_depth = pp.depth;
      s.poisson_pieces = 2;
    }
  }
  if (one_piece && options.library == MeshLibrary::kOpen3d) {
    std::tie(mesh, densities) =
        Poisson(pcd, s.poisson_depth, width_mm, static_cast<float>(kScale), options.threads);
  } else if (one_piece) {
    internal::IndexedMesh m;
    mesh = std::make_shared<open3d::geometry::TriangleMesh>();
    s.poisson_depth = 0;  // no octree
    s.cell_mm = 0;
    if (internal::CgalPoisson(pcd.points_, pcd.normals_, s.spacing_mm, &m)) {
      mesh->vertices_ = std::move(m.vertices);
      for (const auto& t : m.triangles) mesh->triangles_.emplace_back(t[0], t[1], t[2]);
    }
  }
  s.poisson_s = timer.ElapsedSeconds();
  timer.Restart();
  s.poisson_triangles = static_cast<int64_t>(mesh->triangles_.size());
  if (mesh->triangles_.empty()) {
    return Fail(std::move(result), MeshStatus::kFailed, "Poisson reconstruction gave no triangles");
  }

  if (!options.watertight) {
    // Low support: low Poisson density, or far from every measured point.
    const double max_dist_mm = options.trim_distance_factor * s.spacing_mm;
    const double min_density = options.trim_density_quantile > 0 && !densities.empty()
                                   ? Quantile(densities, options.trim_density_quantile)
                                   : -std::numeric_limits<double>::infinity();
    std::vector<uint8_t> remove(mesh->vertices_.size(), 0);
    tbb::parallel_for(size_t{0}, mesh->vertices_.size(), [&](size_t v) {
      const bool far = tree.Nearest(mesh->vertices_[v]).second > max_dist_mm * max_dist_mm;
      remove[v] = far || (!densities.empty() && densities[v] < min_density);
    });
    std::vector<bool> mask(remove.begin(), remove.end());
    s.trimmed_vertices = std::count(remove.begin(), remove.end(), 1);
    mesh->RemoveVerticesByMask(mask);
    mesh->RemoveUnreferencedVertices();
  } else if (!mesh->IsEdgeManifold(/*allow_boundary_edges=*/false) || !mesh->IsVertexManifold()) {
    // Open3D's Poisson keeps Neumann conditions on its cube: the surface of an open scan
    // (the part's plate, seen from above only) runs into the cube's faces and ends there.
    internal::IndexedMesh m;
    m.vertices = mesh->vertices_;
    for (const auto& t : mesh->triangles_) m.triangles.push_back({t(0), t(1), t(2)});
    const int closed = internal::CloseHoles(&m);
    if (closed > 0) {
      s.closed_holes = closed;
      mesh->vertices_ = std::move(m.vertices);
      mesh->triangles_.clear();
      for (const auto& t : m.triangles) mesh->triangles_.emplace_back(t[0], t[1], t[2]);
      mesh->vertex_normals_.clear();
    }
  }

  s.trim_s = timer.ElapsedSeconds();
  timer.Restart();
  if (options.project_to_points && !mesh->vertices_.empty()) {
    mesh->ComputeVertexNormals();
    const Projection moved =
        ProjectOntoPoints(tree, pcd.normals_, s.spacing_mm, options, mesh.get());
    s.projected_vertices = moved.moved;
    s.projection_rms_mm = moved.rms_mm;
    s.projection_max_mm = moved.max_mm;
  }
  s.project_s = timer.ElapsedSeconds();
  timer.Restart();

  if (options.max_triangles > 0 &&
      static_cast<int64_t>(mesh->triangles_.size()) > options.max_triangles) {
    auto decimated = SimplifyQuadric(*mesh, options.max_triangles);
    if (!decimated->triangles_.empty()) {
      TriangleMesh decimated_mesh;
      decimated_mesh.vertices = decimated->vertices_;
      decimated_mesh.triangles = Triangles(*decimated);
      const MeshIndex surface(std::move(decimated_mesh));
      std::vector<double> d(mesh->vertices_.size());
      tbb::parallel_for(size_t{0}, d.size(), [&](size_t v) {
        d[v] = std::abs(surface.SignedDistance(mesh->vertices_[v]));
      });
      double sum_sq = 0, max_d = 0;
      for (double x : d) sum_sq += x * x, max_d = std::max(max_d, x);
      s.decimated = true;
      s.decimation_rms_mm = std::sqrt(sum_sq / std::max<size_t>(d.size(), 1));
      s.decimation_max_mm = max_d;
      mesh = decimated;
    }
  }
  s.trim_s += timer.ElapsedSeconds();
  timer.Restart();
  mesh->ComputeVertexNormals();
  // Closed and manifold (Open3D's IsWatertight adds a self-intersection test that is
  // quadratic in the triangle count). Edges counted once by sorting (Open3D's
  // GetNonManifoldEdges builds a hash map of all edges per call).
  std::tie(s.boundary_edges, s.non_manifold_edges) = CountOddEdges(*mesh);
  const int64_t odd_edges = s.boundary_edges + s.non_manifold_edges;
  s.non_manifold_vertices = static_cast<int64_t>(mesh->GetNonManifoldVertices().size());
  s.watertight = odd_edges == 0 && s.non_manifold_vertices == 0;
  result.mesh.vertices = mesh->vertices_;
  result.mesh.normals = mesh->vertex_normals_;
  result.mesh.triangles = Triangles(*mesh);
  s.vertices = static_cast<int64_t>(result.mesh.NumVertices());
  s.triangles = static_cast<int64_t>(result.mesh.NumTriangles());
  if (result.mesh.triangles.empty()) {
    return Fail(std::move(result), MeshStatus::kFailed, "no triangle left after trimming");
  }
  s.check_s = timer.ElapsedSeconds();
  s.total_s = total.ElapsedSeconds();
  return result;
}

TriangleMesh DecimateMesh(const TriangleMesh& mesh, int64_t max_triangles,
                          std::vector<int64_t>* source_vertex) {
  if (max_triangles < 4) {
    throw Error(util::StrCat("DecimateMesh: max_triangles ", max_triangles, " must be >= 4"));
  }
  const size_t nv = mesh.vertices.size();
  if (static_cast<int64_t>(mesh.NumTriangles()) <= max_triangles) {
    if (source_vertex) {
      source_vertex->resize(nv);
      for (size_t v = 0; v < nv; ++v) (*source_vertex)[v] = static_cast<int64_t>(v);
    }
    return mesh;
  }
  // meshoptimizer takes float positions: relative to the bounding box's centre they keep
  // ~0.1 um on a part of a few hundred mm, far below the collapses' errors.
  Eigen::Vector3d lo, hi;
  mesh.Bounds(&lo, &hi);
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  std::vector<float> positions(3 * nv);
  for (size_t v = 0; v < nv; ++v) {
    for (int k = 0; k < 3; ++k)
      positions[3 * v + k] = static_cast<float>(mesh.vertices[v](k) - centre(k));
  }
  std::vector<unsigned int> indices;
  indices.reserve(3 * mesh.NumTriangles());
  for (const TriangleMesh::Triangle& t : mesh.triangles) {
    for (int32_t v : t) indices.push_back(static_cast<unsigned int>(v));
  }
  const size_t target = 3 * static_cast<size_t>(max_triangles);
  // Edge collapses by quadric error with no error bound (target_error: relative to the mesh's
  // extent), so that only the triangle count stops them; borders stay where they are.
  std::vector<unsigned int> out(indices.size());
  size_t count = meshopt_simplify(out.data(), indices.data(), indices.size(), positions.data(), nv,
                                  3 * sizeof(float), target, 1e3f, 0, nullptr);
  out.resize(count);
  // Where collapses stop short of the count (a mesh of many small pieces or borders), the
  // sloppy simplifier (vertex clustering) takes the rest, with a smaller target until it fits.
  for (size_t sloppy_target = target; out.size() > target && sloppy_target >= 12;
       sloppy_target = sloppy_target * 7 / 10) {
    std::vector<unsigned int> sloppy(out.size());
    count = meshopt_simplifySloppy(sloppy.data(), out.data(), out.size(), positions.data(), nv,
                                   3 * sizeof(float), sloppy_target / 3 * 3, 1e3f, nullptr);
    sloppy.resize(count);
    if (sloppy.size() <= target) out = std::move(sloppy);
  }
  if (out.size() > target) {
    throw Error(util::StrCat("DecimateMesh: cannot decimate ", mesh.NumTriangles(),
                             " triangles to ", max_triangles));
  }
  // The kept vertices in their original order (the output's vertices are the input's).
  std::vector<int32_t> new_index(nv, -1);
  for (unsigned int v : out) new_index[v] = 0;
  TriangleMesh result;
  if (source_vertex) source_vertex->clear();
  for (size_t v = 0; v < nv; ++v) {
    if (new_index[v] < 0) continue;
    new_index[v] = static_cast<int32_t>(result.vertices.size());
    result.vertices.push_back(mesh.vertices[v]);
    if (source_vertex) source_vertex->push_back(static_cast<int64_t>(v));
  }
  result.triangles.reserve(out.size() / 3);
  for (size_t i = 0; i + 2 < out.size(); i += 3) {
    result.triangles.push_back({new_index[out[i]], new_index[out[i + 1]], new_index[out[i + 2]]});
  }
  if (mesh.has_normals()) result.ComputeVertexNormals();
  return result;
}

void WriteMeshFile(const std::filesystem::path& path, const MeshResult& mesh) {
  if (!util::HasExtension(path, {".ply", ".stl"})) {
    throw Error(util::StrCat(path.string(), ": unknown mesh format '", path.extension().string(),
                             "' (expected .ply or .stl)"));
  }
  io::WriteMesh(path, mesh.mesh, {"fringe fuse: screened Poisson mesh, vertex normals"});
}

}  // namespace fringe::fusion
