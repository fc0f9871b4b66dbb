// The scan report's pictures of meshes: shaded renderings of a triangle mesh
// (fringe::MeshIndex, an Embree ray caster), and its interactive 3D view (ScanScene).
// The page itself and the other picture helpers (colour maps, colour bars, histograms) are
// io/report.h.
//
// Thread safety: plain values; the free functions have no shared state.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/camera.h"
#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/geometry/triangle_mesh.h"
#include "fringe/io/report.h"

namespace fringe::pipeline {

// The page and its picture helpers are io's (io/report.h); the scan report uses them by these
// names.
using io::Base64;
using io::ColourBar;
using io::ColourMapWithBar;
using io::DeviationRange;
using io::DisplayRange;
using io::HistogramImage;
using io::Report;
using io::ReportImage;
using io::ReportScene;
using io::ReportSection;
using io::ReportTable;

// Renderings of one mesh from several directions: the mesh's Embree scene is built once (a
// few seconds for a scan's millions of triangles) and every picture casts its rays in
// parallel. Holds a reference to `mesh`, which must outlive it. Methods as the free functions
// below.
class MeshRenderer {
 public:
  explicit MeshRenderer(const TriangleMesh& mesh);
  ~MeshRenderer();
  MeshRenderer(const MeshRenderer&) = delete;
  MeshRenderer& operator=(const MeshRenderer&) = delete;
  cv::Mat Render(const Eigen::Vector3d& view_dir, int width_px = 480, int height_px = 360) const;
  // Throws fringe::Error when vertex_values does not have one value per vertex.
  cv::Mat RenderColoured(const std::vector<double>& vertex_values, double lo, double hi,
                         const std::string& unit, const Eigen::Vector3d& view_dir,
                         int width_px = 480, int height_px = 360) const;

 private:
  template <typename Paint>
  void Cast(const Eigen::Vector3d& view_dir, int width_px, int height_px, Paint paint) const;
  struct Impl;
  const TriangleMesh& mesh_;
  std::unique_ptr<Impl> impl_;
};

// Lambert-shaded rendering of a triangle mesh seen from `view_dir` (unit vector from the eye
// toward the mesh, the mesh's frame; the frame's z is up on the picture unless the view looks
// along z), orthographic, fitted to the mesh's bounding sphere, on a width_px x height_px image
// (CV_8UC1; background black). Embree ray casting (fringe::MeshIndex).
cv::Mat RenderMesh(const TriangleMesh& mesh, const Eigen::Vector3d& view_dir, int width_px = 480,
                   int height_px = 360);
// The same rendering coloured by a per-vertex value (turbo colour map from lo to hi, shaded;
// NaN values grey), with a colour bar labelled `unit` below (CV_8UC3). vertex_values has one
// entry per vertex; a hit takes the value of the hit triangle's vertices, interpolated.
cv::Mat RenderMeshColoured(const TriangleMesh& mesh, const std::vector<double>& vertex_values,
                           double lo, double hi, const std::string& unit,
                           const Eigen::Vector3d& view_dir, int width_px = 480,
                           int height_px = 360);

// What the scan report's 3D view shows: the mesh, a sample of the fused points, the values
// they can be coloured by (height, signed deviation, the view a point came from, the fusion's
// support and quality), the markers and each view's sensor at its registered pose. World frame
// (that of mesh.ply and fused.ply), mm. The pointers must outlive ScanScene's call; null or
// empty: not shown.
struct ScanSceneInput {
  const TriangleMesh* mesh = nullptr;
  const std::vector<double>* mesh_deviation_mm = nullptr;  // per mesh vertex (NaN: none)
  DeviationRange deviation_range;                          // its colours
  std::string deviation_what = "signed deviation from truth, mm";
  const PointCloud* fused = nullptr;                     // with quality (fused.ply)
  const std::vector<uint16_t>* fused_support = nullptr;  // per fused point: views merged
  // Per fused point: the view it came from, an index into fused_view_names.
  const std::vector<uint16_t>* fused_view = nullptr;
  std::vector<std::string> fused_view_names;
  struct Sensor {
    std::string name;  // the view's name (as in the report's tables)
    Rigid3d world_from_sensor;
    CameraModel camera;  // the sensor frame's camera (the left one)
  };
  std::vector<Sensor> sensors;
  struct Marker {
    int id = 0;
    Eigen::Vector3d centre_in_world = Eigen::Vector3d::Zero();
    double radius_mm = 1;
    int views = 0;  // the views that saw it
  };
  std::vector<Marker> markers;
  Rigid3d display_from_world;  // z up in the view, as in the report's pictures
};

struct ScanSceneOptions {
  // The mesh is decimated (fusion::DecimateMesh) to at most this many triangles, and the fused
  // points sampled to at most max_points: the page stays light (the demo's report ~15 MB) and
  // turns smoothly with software rendering; mesh.ply and fused.ply keep everything. >= 4, >= 0.
  int64_t max_triangles = 200000;
  int64_t max_points = 100000;
  void Check() const;
};

// The 3D view of a scan: the description and arrays io::ReportScene embeds (docs/formats.md,
// "The report's 3D view"). A decimated mesh's vertices are vertices of `mesh` and keep their
// deviation; every vertex takes the view, support and quality of the nearest fused point.
// Throws fringe::Error for bad options or per-vertex / per-point arrays of the wrong size.
ReportScene ScanScene(const ScanSceneInput& input, const ScanSceneOptions& options = {});

}  // namespace fringe::pipeline
