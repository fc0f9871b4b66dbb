// Point clouds: unorganized (a list of points) and organized (one slot per camera pixel).
//
// Storage is struct-of-arrays: `points` always, the other attributes either empty (absent) or
// with one entry per point. Positions in millimetres, in the frame the owner names (a view's
// cloud is in its left camera frame; a fused cloud in the world frame).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace fringe {

using Color3u8 = std::array<uint8_t, 3>;

struct PointCloud {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3d> normals;  // unit length (NaN: that point has none), or empty
  std::vector<Color3u8> colors;          // RGB, or empty
  std::vector<float> intensity;          // texture grey value (0-255 scale), or empty
  std::vector<float> quality;            // larger is better (e.g. fringe modulation), or empty
  std::vector<float> residual_px;        // triangulation reprojection residual (px), or empty

  size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool has_normals() const { return !normals.empty(); }
  bool has_colors() const { return !colors.empty(); }
  bool has_intensity() const { return !intensity.empty(); }
  bool has_quality() const { return !quality.empty(); }
  bool has_residual() const { return !residual_px.empty(); }

  // Throws fringe::Error when an attribute is neither empty nor of size() entries.
  void CheckConsistent() const;
  // Appends point i of `other` (attributes must be present in both or absent in both).
  void PushBackFrom(const PointCloud& other, size_t i);
  void Reserve(size_t n);
  // Axis-aligned bounds; both NaN when empty.
  void Bounds(Eigen::Vector3d* min, Eigen::Vector3d* max) const;
};

// A cloud on the image grid of the camera that measured it: slot r * width + c belongs to pixel
// (c, r). Invalid slots have valid[i] == 0 and unspecified (NaN) position. Later stages (grid
// normals, fusion) rely on this neighbourhood structure.
struct OrganizedPointCloud {
  int width = 0;
  int height = 0;
  PointCloud cloud;            // width * height entries
  std::vector<uint8_t> valid;  // width * height entries, 1 where the point is measured

  OrganizedPointCloud() = default;
  // All slots invalid, positions NaN; attributes allocated per the flags.
  OrganizedPointCloud(int width, int height, bool with_normals = false, bool with_intensity = false,
                      bool with_quality = false);

  size_t index(int col, int row) const { return static_cast<size_t>(row) * width + col; }
  size_t NumValid() const;
  // The valid points as an unorganized cloud (grid order).
  PointCloud Compact() const;
  // Throws fringe::Error when sizes disagree with width * height.
  void CheckConsistent() const;
};

}  // namespace fringe
