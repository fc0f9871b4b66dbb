#include "fringe/pipeline/memory_budget.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "fringe/util/memory.h"

namespace fringe::pipeline {

double ResolveMemoryLimitGiB(double limit_gib) {
  if (limit_gib > 0) return limit_gib;
  const double physical = util::PhysicalMemoryGiB();
  return physical > 0 ? kDefaultMemoryFraction * physical : 8.0;
}

double ViewWorkBytes(int width, int height, int images_per_camera, int cameras, int bit_depth) {
  constexpr double kWorkBytesPerPixel = 115;
  const double pixels = double(width) * double(height);
  const double image_bytes = bit_depth > 8 ? 2.0 : 1.0;
  return pixels * (image_bytes * images_per_camera * cameras + kWorkBytesPerPixel);
}

namespace {

// The largest number of points of one tile (core + margin) of edge `tile` over `box`.
double MaxTilePoints(const std::vector<Eigen::Vector3d>& samples, double sample_weight,
                     const Eigen::AlignedBox3d& box, double tile, double margin) {
  Eigen::Array3i n;
  for (int a = 0; a < 3; ++a)
    n[a] = static_cast<int>(std::max(1.0, std::ceil(box.sizes()[a] / tile)));
  const auto cell = [&](double x, int a) {
    const double c = std::floor((x - box.min()[a]) / tile);
    return static_cast<int>(std::clamp(c, 0.0, double(n[a] - 1)));
  };
  std::unordered_map<int64_t, double> count;
  double largest = 0;
  for (const Eigen::Vector3d& p : samples) {
    Eigen::Array3i lo, hi;
    for (int a = 0; a < 3; ++a) lo[a] = cell(p[a] - margin, a), hi[a] = cell(p[a] + margin, a);
    for (int z = lo[2]; z <= hi[2]; ++z) {
      for (int y = lo[1]; y <= hi[1]; ++y) {
        for (int x = lo[0]; x <= hi[0]; ++x) {
          double& c = count[(int64_t{z} * n[1] + y) * n[0] + x];
          c += sample_weight;
          largest = std::max(largest, c);
        }
      }
    }
  }
  return largest;
}

}  // namespace

double ChooseTileSize(const std::vector<Eigen::Vector3d>& samples, double sample_weight,
                      double margin_mm, double max_points, double min_tile_mm,
                      double* max_tile_points) {
  const double all = double(samples.size()) * sample_weight;
  if (max_tile_points) *max_tile_points = all;
  if (all <= max_points) return std::numeric_limits<double>::infinity();
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : samples) box.extend(p);
  for (double tile = box.sizes().maxCoeff(); tile >= min_tile_mm; tile *= 0.8) {
    const double largest = MaxTilePoints(samples, sample_weight, box, tile, margin_mm);
    if (max_tile_points) *max_tile_points = largest;
    if (largest <= max_points) return tile;
  }
  return 0;
}

}  // namespace fringe::pipeline
