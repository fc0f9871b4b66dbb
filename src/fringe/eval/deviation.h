// Deviation of a measured cloud from a reference surface (a triangle mesh): signed point-to-
// surface distances and their statistics, and a colour-map picture.
//
// Closest points and their signs come from fringe::MeshIndex (geometry/mesh_index.h: exact
// closest point on the triangles, angle-weighted pseudo-normals; positive outside).
//
// Units: millimetres; cloud and mesh must be in the same frame.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/mesh_index.h"
#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/triangle_mesh.h"

namespace fringe::eval {

struct DeviationOptions {
  // Points farther than this from the surface are counted as unmatched and left out of the
  // statistics (they belong to something the mesh does not model), mm, > 0.
  double max_distance_mm = 2.0;
  void Check() const;
};

struct DeviationStats {
  int points = 0;      // points with a distance
  int unmatched = 0;   // farther than max_distance_mm
  double mean_mm = 0;  // signed mean
  double rms_mm = 0;
  double p95_mm = 0;  // 95th percentile of |d|
  double max_mm = 0;  // max |d|
  std::string BriefReport() const;
};
// As `fringe evaluate --truth --json` prints it.
nlohmann::json ToJson(const DeviationStats& s);

// Signed distance of every point (NaN for unmatched and non-finite points) and the statistics.
DeviationStats DeviationFromMesh(const PointCloud& cloud, const MeshIndex& mesh,
                                 const DeviationOptions& options = {},
                                 std::vector<double>* signed_mm = nullptr);

// Picture of per-point deviations on an organized cloud's grid (CV_8UC3 BGR): blue = -range_mm
// (inside), green = 0, red = +range_mm (outside), dark grey where there is no value.
// distances has one entry per grid slot (NaN = none).
cv::Mat DeviationColorMap(int width, int height, const std::vector<double>& distances,
                          double range_mm);
// The same for an unorganized cloud: points projected orthographically along the cloud frame's
// z axis onto an image of at most max_size_px on its longer side.
cv::Mat DeviationColorMapTopView(const PointCloud& cloud, const std::vector<double>& distances,
                                 double range_mm, int max_size_px = 1024);

}  // namespace fringe::eval
