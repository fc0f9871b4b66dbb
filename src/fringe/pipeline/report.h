// The scan report's pictures of meshes: shaded renderings of a triangle mesh cast with Embree
// (sim::RayCaster, the virtual scanner's ray caster). The page itself and the other picture
// helpers (colour maps, colour bars, histograms) are io/report.h.
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

#include "fringe/geometry/triangle_mesh.h"
#include "fringe/io/report.h"

namespace fringe::pipeline {

// The page and its picture helpers are io's (io/report.h); the scan report uses them by these
// names.
using io::Base64;
using io::ColourBar;
using io::ColourMapWithBar;
using io::DisplayRange;
using io::HistogramImage;
using io::Report;
using io::ReportImage;
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
// (CV_8UC1; background black). Embree ray casting (sim::RayCaster).
cv::Mat RenderMesh(const TriangleMesh& mesh, const Eigen::Vector3d& view_dir, int width_px = 480,
                   int height_px = 360);
// The same rendering coloured by a per-vertex value (turbo colour map from lo to hi, shaded;
// NaN values grey), with a colour bar labelled `unit` below (CV_8UC3). vertex_values has one
// entry per vertex; a hit takes the value of the hit triangle's vertices, interpolated.
cv::Mat RenderMeshColoured(const TriangleMesh& mesh, const std::vector<double>& vertex_values,
                           double lo, double hi, const std::string& unit,
                           const Eigen::Vector3d& view_dir, int width_px = 480,
                           int height_px = 360);

}  // namespace fringe::pipeline
