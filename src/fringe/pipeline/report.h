// The scan report: one self-contained HTML page (images embedded as base64 PNG data URIs, no
// external URL, no script) with the pictures of a scan and all its figures as tables, and the
// picture helpers the pipeline fills it with: false-colour maps of per-pixel values with a
// colour bar legend in their unit, and shaded renderings of a triangle mesh cast with Embree
// (sim::RayCaster, the virtual scanner's ray caster).
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

namespace fringe::pipeline {

struct ReportImage {
  std::string caption;
  cv::Mat image;  // CV_8UC1 or CV_8UC3 (BGR)
};

struct ReportTable {
  std::string caption;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

struct ReportSection {
  std::string title;
  std::vector<std::string> paragraphs;  // plain text (escaped when rendered)
  std::vector<ReportTable> tables;
  std::vector<ReportImage> images;
};

struct Report {
  std::string title;
  std::vector<ReportSection> sections;

  // The page. Throws fringe::Error when an image cannot be encoded.
  std::string ToHtml() const;
  // Writes ToHtml() to `path` atomically.
  void Write(const std::filesystem::path& path) const;
};

// Standard base64 (RFC 4648, with padding).
std::string Base64(const std::vector<uint8_t>& bytes);

// False-colour picture of a CV_32F map (turbo colour map: lo blue ... hi red), NaN drawn dark
// grey, with a colour bar below labelled in `unit` from lo to hi. The map is shrunk to at most
// max_width_px wide (area averaging of the finite values).
cv::Mat ColourMapWithBar(const cv::Mat& values, double lo, double hi, const std::string& unit,
                         int max_width_px = 640);
// Robust display range: the p and 1 - p quantiles of the finite values (lo == hi widened by 1).
std::array<double, 2> DisplayRange(const cv::Mat& values, double p = 0.01);

// The colour bar ColourMapWithBar puts under its map: a turbo gradient from lo to hi, five
// labelled ticks and `unit` below, width_px wide (CV_8UC3, white background).
cv::Mat ColourBar(int width_px, double lo, double hi, const std::string& unit);

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

// Histogram of `values` in [lo, hi] (values outside are counted in the end bins and the counts
// noted), `bins` bars, x axis labelled `unit`, a vertical marker line at each of `marks` (e.g.
// a threshold); CV_8UC3 on white, width_px x height_px.
cv::Mat HistogramImage(const std::vector<double>& values, double lo, double hi, int bins,
                       const std::string& unit, const std::vector<double>& marks = {},
                       int width_px = 420, int height_px = 220);

}  // namespace fringe::pipeline
