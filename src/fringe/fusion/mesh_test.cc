#include "fringe/fusion/mesh.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <functional>
#include <vector>

#include "fringe/fusion/fuse.h"
#include "fringe/geometry/mesh_index.h"
#include "fringe/io/mesh_io.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/scene.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/testing/fusion_views.h"
#include "fringe/util/error.h"

namespace fringe::fusion {
namespace {

// The mesh's vertices (and normals) as a point cloud, for the radial-error helpers.
PointCloud VertexCloud(const MeshResult& m) {
  PointCloud c;
  c.points = m.mesh.vertices;
  c.normals = m.mesh.normals;
  return c;
}

constexpr double kRadiusMm = 30;

// Six noisy views all around a floating sphere (centre at the origin), fused.
const FusionResult& FusedSphere() {
  static const FusionResult fused = [] {
    const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.25);
    const sim::Renderer renderer(sim::MakeSphereScene(kRadiusMm, false), rig);
    const std::vector<Eigen::Vector3d> dirs = {{1, 0, 0.3},   {0, 1, -0.3},  {-1, 0, 0.3},
                                               {0, -1, -0.3}, {0.2, 0.1, 1}, {-0.1, 0.2, -1}};
    std::vector<FusionView> views;
    for (size_t v = 0; v < dirs.size(); ++v) {
      const Rigid3d pose =
          sim::SensorPoseLookingAt(rig, Eigen::Vector3d::Zero(), dirs[v].normalized());
      views.push_back(testing::TruthView(renderer, std::to_string(v), pose, pose, 0.02, v + 1));
    }
    return FuseViews(views);
  }();
  return fused;
}

// Vertices of a mesh of the origin-centred sphere whose normal points towards the centre
// (outward normals point away from it).
int InwardNormals(const MeshResult& m) {
  int inward = 0;
  for (size_t i = 0; i < m.mesh.NumVertices(); ++i) {
    inward += m.mesh.normals[i].dot(m.mesh.vertices[i]) < 0;
  }
  return inward;
}

Eigen::Vector2d RadialErrorRmsMax(const PointCloud& vertices) {
  double sum_sq = 0, max_abs = 0;
  for (const auto& p : vertices.points) {
    const double e = p.norm() - kRadiusMm;
    sum_sq += e * e;
    max_abs = std::max(max_abs, std::abs(e));
  }
  return {std::sqrt(sum_sq / vertices.size()), max_abs};
}

TEST(Mesh, DefaultOptionsPassCheck) {
  EXPECT_NO_THROW(MeshOptions().Check());
  MeshOptions o;
  o.poisson_depth = 30;
  EXPECT_THROW(o.Check(), Error);
}

TEST(Mesh, FusedSphereIsWatertightAndWithinToleranceOfTheSphere) {
  // Poisson on 0.8 mm sampling with octree cells of ~0.5 mm: a smooth surface within 0.05 mm
  // RMS (0.2 mm at worst) of the true sphere.
  constexpr double kRmsTolMm = 0.05;
  constexpr double kMaxTolMm = 0.2;
  const FusionResult& fused = FusedSphere();
  ASSERT_EQ(fused.summary.status, FusionStatus::kOk) << fused.summary.BriefReport();
  MeshOptions options;
  options.poisson_depth = 7;
  options.watertight = true;
  const MeshResult m = MeshPoisson(fused.fused, options);
  SCOPED_TRACE(m.summary.BriefReport());
  ASSERT_TRUE(m.summary.ok());
  EXPECT_TRUE(m.summary.watertight);
  EXPECT_EQ(m.summary.trimmed_vertices, 0);
  const Eigen::Vector2d err = RadialErrorRmsMax(VertexCloud(m));
  EXPECT_LT(err[0], kRmsTolMm);
  EXPECT_LT(err[1], kMaxTolMm);
  EXPECT_EQ(InwardNormals(m), 0);
}

TEST(Mesh, CgalPoissonOfTheFusedSphereIsWatertightAndWithinToleranceOfTheSphere) {
  // CGAL's (unscreened) Poisson meshes its implicit surface with facets up to 30 spacings and
  // a surface distance of 0.375 spacing (~0.3 mm): farther from the sphere than Open3D's
  // screened Poisson (0.088 mm RMS, 0.32 mm at worst measured, against < 0.05 / 0.2 mm
  // above), closed all the same.
  constexpr double kRmsTolMm = 0.1;
  constexpr double kMaxTolMm = 0.4;
  const FusionResult& fused = FusedSphere();
  ASSERT_EQ(fused.summary.status, FusionStatus::kOk) << fused.summary.BriefReport();
  MeshOptions options;
  options.library = MeshLibrary::kCgal;
  options.watertight = true;
  const MeshResult m = MeshPoisson(fused.fused, options);
  SCOPED_TRACE(m.summary.BriefReport());
  ASSERT_TRUE(m.summary.ok());
  EXPECT_EQ(m.summary.library, "cgal");
  EXPECT_TRUE(m.summary.watertight);
  const Eigen::Vector2d err = RadialErrorRmsMax(VertexCloud(m));
  EXPECT_LT(err[0], kRmsTolMm);
  EXPECT_LT(err[1], kMaxTolMm);
  EXPECT_EQ(InwardNormals(m), 0);
}

TEST(Mesh, WatertightClosesTheMeshOfAnOpenScan) {
  // A plane seen from one side: Open3D's Poisson surface runs into its bounding cube and ends
  // there (open); --watertight closes those holes and keeps the measured surface (on the plane
  // within a tenth of the 0.8 mm point spacing).
  constexpr double kRmsTolMm = 0.08;
  const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.25);
  const sim::Renderer renderer(sim::MakePlaneScene(), rig);
  std::vector<FusionView> views;
  for (double tilt : {-15.0, 15.0}) {
    const double a = tilt * M_PI / 180;
    const Rigid3d pose = sim::SensorPoseLookingAt(rig, Eigen::Vector3d(-tilt, 0, 0),
                                                  Eigen::Vector3d(std::sin(a), 0.1, std::cos(a)));
    views.push_back(testing::TruthView(renderer, std::to_string(views.size()), pose, pose, 0.02,
                                       views.size() + 1));
  }
  const FusionResult fused = FuseViews(views);
  ASSERT_EQ(fused.summary.status, FusionStatus::kOk) << fused.summary.BriefReport();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
  for (const auto& p : fused.fused.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  MeshOptions options;
  options.poisson_depth = 7;
  const MeshResult open = MeshPoisson(fused.fused, options);
  ASSERT_TRUE(open.summary.ok()) << open.summary.BriefReport();
  EXPECT_FALSE(open.summary.watertight);
  options.watertight = true;
  const MeshResult m = MeshPoisson(fused.fused, options);
  SCOPED_TRACE(m.summary.BriefReport());
  ASSERT_TRUE(m.summary.ok());
  EXPECT_GT(m.summary.closed_holes, 0);
  EXPECT_TRUE(m.summary.watertight);
  EXPECT_EQ(m.summary.boundary_edges, 0);
  EXPECT_EQ(m.summary.non_manifold_edges, 0);
  EXPECT_EQ(m.summary.non_manifold_vertices, 0);
  // Closing adds surface and changes none: every vertex of the trimmed mesh (the measured
  // part) lies on the closed one.
  const MeshIndex closed(m.mesh);
  double max_off_mm = 0;
  for (const auto& p : open.mesh.vertices) {
    max_off_mm = std::max(max_off_mm, std::abs(closed.SignedDistance(p)));
  }
  EXPECT_LT(max_off_mm, 1e-6);
  // The measured part (its inner 80 %, away from the open rim) is on the plane.
  const Eigen::Vector3d mid = (lo + hi) / 2, half = 0.4 * (hi - lo);
  double sum_sq = 0;
  int n = 0;
  for (const auto& p : open.mesh.vertices) {
    if (std::abs(p.x() - mid.x()) > half.x() || std::abs(p.y() - mid.y()) > half.y()) continue;
    sum_sq += p.z() * p.z();
    ++n;
  }
  ASSERT_GT(n, 1000);
  EXPECT_LT(std::sqrt(sum_sq / n), kRmsTolMm);
}

TEST(Mesh, AutomaticDepthFollowsThePointSpacingAndExtent) {
  // The sphere's fused cloud (~0.8 mm spacing, 60 mm across) and every 4th of its points (about
  // twice the spacing): the coarser cloud gets a shallower octree, and the finest cell of each
  // is at most cell_spacings spacings.
  const FusionResult& fused = FusedSphere();
  PointCloud sparse;
  for (size_t i = 0; i < fused.fused.size(); i += 4) sparse.PushBackFrom(fused.fused, i);
  const MeshOptions options;  // poisson_depth 0: automatic
  const MeshResult fine = MeshPoisson(fused.fused, options);
  const MeshResult coarse = MeshPoisson(sparse, options);
  ASSERT_TRUE(fine.summary.ok()) << fine.summary.BriefReport();
  ASSERT_TRUE(coarse.summary.ok()) << coarse.summary.BriefReport();
  EXPECT_GT(fine.summary.spacing_mm, 0.5);
  EXPECT_LT(fine.summary.spacing_mm, 1.2);
  EXPECT_GT(coarse.summary.spacing_mm, 1.4 * fine.summary.spacing_mm);
  EXPECT_LT(coarse.summary.poisson_depth, fine.summary.poisson_depth);
  for (const MeshResult* m : {&fine, &coarse}) {
    const double extent_mm = 1.1 * 60;  // Poisson's cube around the sphere, about
    const double cell_mm = extent_mm / std::pow(2.0, m->summary.poisson_depth);
    EXPECT_LE(cell_mm, 1.05 * options.cell_spacings * m->summary.spacing_mm)
        << m->summary.BriefReport();
    EXPECT_GT(cell_mm, 0.5 * 0.95 * options.cell_spacings * m->summary.spacing_mm)
        << m->summary.BriefReport();
  }
}

TEST(Mesh, WantedResolutionCoarsensTheAutomaticDepthButNeverRefinesIt) {
  // The sphere's fused cloud (~0.8 mm spacing: the data allow ~1.6 mm cells). A wanted
  // resolution of 4 mm makes the finest cell at most 4 mm and more than half that; a wanted
  // resolution finer than the data allow changes nothing.
  const FusionResult& fused = FusedSphere();
  const MeshResult data = MeshPoisson(fused.fused, MeshOptions());
  MeshOptions coarse_options;
  coarse_options.resolution_mm = 4;
  const MeshResult coarse = MeshPoisson(fused.fused, coarse_options);
  MeshOptions fine_options;
  fine_options.resolution_mm = 0.1;
  const MeshResult fine = MeshPoisson(fused.fused, fine_options);
  for (const MeshResult* m : {&data, &coarse, &fine}) {
    ASSERT_TRUE(m->summary.ok()) << m->summary.BriefReport();
  }
  EXPECT_LE(coarse.summary.cell_mm, coarse_options.resolution_mm);
  EXPECT_GT(coarse.summary.cell_mm, 0.5 * coarse_options.resolution_mm);
  EXPECT_LT(coarse.summary.poisson_depth, data.summary.poisson_depth);
  EXPECT_LT(coarse.summary.triangles, data.summary.triangles);
  EXPECT_EQ(fine.summary.poisson_depth, data.summary.poisson_depth);
  MeshOptions bad;
  bad.resolution_mm = -1;
  EXPECT_THROW(bad.Check(), Error);
}

TEST(Mesh, TwoPiecesJoinIntoOneSurfaceAsCloseToTheSphereAsOnePiece) {
  // The fused sphere meshed in one Poisson problem and in two pieces joined on a grid plane
  // (MeshOptions::poisson_pieces): the joined surface is as close to the sphere, the seam is
  // joined (a crack adds two boundary edges per unmatched seam vertex at most; an unjoined seam
  // would add about two per seam vertex), and the mesh does not depend on the thread count.
  // Trimming differs a little (the density quantile is taken over another set of vertices).
  constexpr double kRmsTolMm = 0.05;
  constexpr double kMaxTolMm = 0.2;
  constexpr double kMaxUnmatchedFraction = 0.05;
  const FusionResult& fused = FusedSphere();
  MeshOptions one_options;
  one_options.poisson_pieces = 1;
  MeshOptions two_options;
  two_options.poisson_pieces = 2;
  const MeshResult one = MeshPoisson(fused.fused, one_options);
  const MeshResult two = MeshPoisson(fused.fused, two_options);
  SCOPED_TRACE(one.summary.BriefReport() + "\n" + two.summary.BriefReport());
  ASSERT_TRUE(one.summary.ok());
  ASSERT_TRUE(two.summary.ok());
  EXPECT_EQ(one.summary.poisson_pieces, 1);
  ASSERT_EQ(two.summary.poisson_pieces, 2);
  EXPECT_EQ(two.summary.poisson_depth, one.summary.poisson_depth);
  EXPECT_DOUBLE_EQ(two.summary.cell_mm, one.summary.cell_mm);
  ASSERT_GT(two.summary.seam_vertices, 50);
  EXPECT_LE(two.summary.seam_unmatched, kMaxUnmatchedFraction * two.summary.seam_vertices);
  {
    // Untrimmed, Poisson's sphere is closed: every boundary edge is a crack in the seam.
    MeshOptions untrimmed = two_options;
    untrimmed.trim_density_quantile = 0;
    untrimmed.trim_distance_factor = 1e6;
    const MeshResult closed = MeshPoisson(fused.fused, untrimmed);
    SCOPED_TRACE(closed.summary.BriefReport());
    ASSERT_EQ(closed.summary.poisson_pieces, 2);
    EXPECT_LE(closed.summary.seam_unmatched, kMaxUnmatchedFraction * closed.summary.seam_vertices);
    EXPECT_LE(closed.summary.boundary_edges, 2 * closed.summary.seam_unmatched);
    EXPECT_EQ(closed.summary.non_manifold_edges, 0);
  }
  const Eigen::Vector2d err = RadialErrorRmsMax(VertexCloud(two));
  EXPECT_LT(err[0], kRmsTolMm);
  EXPECT_LT(err[1], kMaxTolMm);
  EXPECT_EQ(InwardNormals(two), 0);
  EXPECT_NEAR(static_cast<double>(two.summary.vertices), static_cast<double>(one.summary.vertices),
              0.02 * one.summary.vertices);
  {
    const tbb::global_control serial(tbb::global_control::max_allowed_parallelism, 1);
    const MeshResult two_serial = MeshPoisson(fused.fused, two_options);
    EXPECT_EQ(two_serial.mesh.vertices, two.mesh.vertices);
    EXPECT_EQ(two_serial.mesh.triangles, two.mesh.triangles);
  }
  // Automatic: two pieces only for surfaces of at least 2 * min_cells_per_piece cells (the
  // sphere's ~4 pi R^2 / cell^2).
  const double sphere_cells =
      4 * M_PI * kRadiusMm * kRadiusMm / (one.summary.cell_mm * one.summary.cell_mm);
  EXPECT_NEAR(one.summary.surface_cells, sphere_cells, 0.3 * sphere_cells);
  MeshOptions automatic;
  EXPECT_EQ(MeshPoisson(fused.fused, automatic).summary.poisson_pieces, 1);  // ~4,500 cells
  automatic.min_cells_per_piece = static_cast<int64_t>(0.3 * one.summary.surface_cells);
  EXPECT_EQ(MeshPoisson(fused.fused, automatic).summary.poisson_pieces, 2);
  // A seam with unjoined vertices is refused when none may stay unjoined (a thin margin makes
  // the pieces disagree more): the one problem's mesh instead, the seam's figures reported.
  MeshOptions strict = two_options;
  strict.piece_margin_cells = 2;
  strict.max_seam_unmatched = 0;
  const MeshResult refused = MeshPoisson(fused.fused, strict);
  ASSERT_TRUE(refused.summary.ok());
  EXPECT_GT(refused.summary.seam_vertices, 50);
  EXPECT_EQ(refused.summary.seam_refused, refused.summary.seam_unmatched > 0);
  EXPECT_EQ(refused.summary.poisson_pieces, refused.summary.seam_refused ? 1 : 2);
  if (refused.summary.seam_refused) {
    EXPECT_EQ(refused.mesh.vertices, one.mesh.vertices);
    EXPECT_EQ(refused.mesh.triangles, one.mesh.triangles);
  }
  MeshOptions bad;
  bad.poisson_pieces = 3;
  EXPECT_THROW(bad.Check(), Error);
}

TEST(Mesh, TrimmingKeepsOnlyTheMeasuredPart) {
  // Half a sphere measured: the closing bubble over the other half must go.
  const double kMaxFromDataMm = MeshOptions().trim_distance_factor * 0.9;  // ~spacing 0.9 mm
  const FusionResult& fused = FusedSphere();
  PointCloud half;
  for (size_t i = 0; i < fused.fused.size(); ++i) {
    if (fused.fused.points[i].z() > 0) half.PushBackFrom(fused.fused, i);
  }
  MeshOptions options;
  options.poisson_depth = 7;
  const MeshResult trimmed = MeshPoisson(half, options);
  SCOPED_TRACE(trimmed.summary.BriefReport());
  ASSERT_TRUE(trimmed.summary.ok());
  EXPECT_FALSE(trimmed.summary.watertight);
  EXPECT_GT(trimmed.summary.trimmed_vertices, 0);
  double min_z = 1e9;
  for (const auto& p : trimmed.mesh.vertices) min_z = std::min(min_z, p.z());
  EXPECT_GT(min_z, -kMaxFromDataMm);
  // Away from the open rim (where Poisson is unconstrained on one side) the surface is as
  // close to the sphere as the closed mesh.
  const PointCloud vertices = VertexCloud(trimmed);
  PointCloud inner;
  for (size_t i = 0; i < vertices.size(); ++i) {
    if (vertices.points[i].z() > 5) inner.PushBackFrom(vertices, i);
  }
  ASSERT_GT(inner.size(), vertices.size() / 2);
  EXPECT_LT(RadialErrorRmsMax(inner)[0], 0.05);
}

TEST(Mesh, ProjectionOntoThePointsMakesACoarseMeshAsAccurateAsItsCloud) {
  // Cells of ~1 mm on a 30 mm sphere sampled at ~0.9 mm with 0.02 mm noise: Poisson alone lies
  // off the sphere by its smoothing; each vertex projected onto the quadric of its nearest
  // points is within the fused cloud's own error (the points' noise averaged, the curvature
  // kept).
  constexpr double kRatioTol = 1.2;  // vertices' radial RMS over the fused points'
  const FusionResult& fused = FusedSphere();
  MeshOptions options;
  options.poisson_depth = 6;
  options.watertight = true;
  options.project_to_points = false;
  const MeshResult poisson = MeshPoisson(fused.fused, options);
  options.project_to_points = true;
  const MeshResult projected = MeshPoisson(fused.fused, options);
  SCOPED_TRACE(poisson.summary.BriefReport() + "\n" + projected.summary.BriefReport());
  ASSERT_TRUE(poisson.summary.ok());
  ASSERT_TRUE(projected.summary.ok());
  EXPECT_EQ(poisson.summary.projected_vertices, 0);
  EXPECT_GT(projected.summary.projected_vertices, projected.summary.vertices * 9 / 10);
  EXPECT_TRUE(projected.summary.watertight);
  EXPECT_EQ(InwardNormals(projected), 0);
  const double cloud_rms = RadialErrorRmsMax(fused.fused)[0];
  const double poisson_rms = RadialErrorRmsMax(VertexCloud(poisson))[0];
  const double projected_rms = RadialErrorRmsMax(VertexCloud(projected))[0];
  EXPECT_LT(projected_rms, poisson_rms);
  EXPECT_LT(projected_rms, kRatioTol * cloud_rms)
      << "cloud " << cloud_rms << ", Poisson " << poisson_rms << " mm";
  // Moves are bounded by max_project_spacings point spacings.
  EXPECT_LE(projected.summary.projection_max_mm,
            options.max_project_spacings * projected.summary.spacing_mm + 1e-12);
}

TEST(Mesh, ProjectionOptionsAreChecked) {
  for (const auto& bad : std::vector<std::function<void(MeshOptions*)>>{
           [](MeshOptions* o) { o->project_neighbours = 3; },
           [](MeshOptions* o) { o->max_project_flatness = 0; },
           [](MeshOptions* o) { o->max_project_spacings = std::nan(""); },
           [](MeshOptions* o) { o->max_surface_cells = 10; }}) {
    MeshOptions o;
    bad(&o);
    EXPECT_THROW(o.Check(), Error);
  }
}

TEST(Mesh, DecimationReportsItsDeviationAndFilesAreWritten) {
  const FusionResult& fused = FusedSphere();
  MeshOptions options;
  options.poisson_depth = 7;
  options.watertight = true;
  options.max_triangles = 2000;
  const MeshResult m = MeshPoisson(fused.fused, options);
  SCOPED_TRACE(m.summary.BriefReport());
  ASSERT_TRUE(m.summary.ok());
  EXPECT_TRUE(m.summary.decimated);
  EXPECT_LE(m.summary.triangles, 2000);
  // A 2000-triangle sphere of radius 30 deviates by ~0.1 mm from the fine one: reported, > 0.
  EXPECT_GT(m.summary.decimation_rms_mm, 0.005);
  EXPECT_LT(m.summary.decimation_max_mm, 1.0);
  EXPECT_GE(m.summary.decimation_max_mm, m.summary.decimation_rms_mm);

  test::TempDir dir;
  WriteMeshFile(dir / "m.ply", m);
  const TriangleMesh d = io::ReadMesh(dir / "m.ply");
  EXPECT_EQ(d.triangles.size(), m.mesh.triangles.size());
  EXPECT_TRUE(d.has_normals());
  WriteMeshFile(dir / "m.stl", m);
  const TriangleMesh stl = io::ReadMesh(dir / "m.stl");
  EXPECT_EQ(stl.triangles.size(), m.mesh.triangles.size());
  EXPECT_THROW(WriteMeshFile(dir / "m.obj", m), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "m.obj"));
}

TEST(Mesh, DecimateMeshKeepsTheShapeWithFewerTriangles) {
  const FusionResult& fused = FusedSphere();
  MeshOptions options;
  options.poisson_depth = 7;
  options.watertight = true;
  const MeshResult m = MeshPoisson(fused.fused, options);
  ASSERT_TRUE(m.summary.ok());
  ASSERT_GT(m.mesh.NumTriangles(), 8000u);
  const TriangleMesh d = DecimateMesh(m.mesh, 2000);
  EXPECT_LE(d.NumTriangles(), 2000u);
  EXPECT_GT(d.NumTriangles(), 1500u);
  EXPECT_NO_THROW(d.Check("decimated"));
  EXPECT_EQ(d.normals.size(), d.vertices.size());
  // Still the sphere of radius 30: the decimated vertices lie on it within 0.5 mm.
  PointCloud vertices;
  vertices.points = d.vertices;
  EXPECT_LT(RadialErrorRmsMax(vertices)[1], 0.5);
  // Nothing to do: the same mesh.
  const TriangleMesh same = DecimateMesh(d, 100000);
  EXPECT_EQ(same.vertices, d.vertices);
  EXPECT_EQ(same.triangles, d.triangles);
  EXPECT_THROW(DecimateMesh(d, 3), Error);
}

TEST(Mesh, BadInputsGiveTheirStatus) {
  PointCloud no_normals;
  for (int i = 0; i < 100; ++i) no_normals.points.emplace_back(i, 0, 0);
  EXPECT_EQ(MeshPoisson(no_normals).summary.status, MeshStatus::kMissingNormals);
  PointCloud few;
  few.points = {{0, 0, 0}, {1, 0, 0}};
  few.normals = {{0, 0, 1}, {0, 0, 1}};
  EXPECT_EQ(MeshPoisson(few).summary.status, MeshStatus::kTooFewPoints);
  EXPECT_EQ(MeshPoisson(PointCloud()).summary.status, MeshStatus::kTooFewPoints);
}

}  // namespace
}  // namespace fringe::fusion
