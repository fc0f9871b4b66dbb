#include "fringe/geometry/point_cloud.h"

#include <limits>

#include "fringe/util/error.h"

namespace fringe {
namespace {

template <typename T>
void CheckAttribute(const std::vector<T>& v, size_t n, const char* name) {
  if (!v.empty() && v.size() != n) {
    throw Error(
        util::StrCat("point cloud: ", name, " has ", v.size(), " entries for ", n, " points"));
  }
}

}  // namespace

void PointCloud::CheckConsistent() const {
  CheckAttribute(normals, size(), "normals");
  CheckAttribute(colors, size(), "colors");
  CheckAttribute(intensity, size(), "intensity");
  CheckAttribute(quality, size(), "quality");
  CheckAttribute(residual_px, size(), "residual_px");
}

void PointCloud::PushBackFrom(const PointCloud& other, size_t i) {
  points.push_back(other.points[i]);
  if (other.has_normals()) normals.push_back(other.normals[i]);
  if (other.has_colors()) colors.push_back(other.colors[i]);
  if (other.has_intensity()) intensity.push_back(other.intensity[i]);
  if (other.has_quality()) quality.push_back(other.quality[i]);
  if (other.has_residual()) residual_px.push_back(other.residual_px[i]);
}

void PointCloud::Reserve(size_t n) {
  points.reserve(n);
  normals.reserve(n);
  colors.reserve(n);
  intensity.reserve(n);
  quality.reserve(n);
  residual_px.reserve(n);
}

void PointCloud::Bounds(Eigen::Vector3d* min, Eigen::Vector3d* max) const {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (points.empty()) {
    *min = *max = Eigen::Vector3d::Constant(nan);
    return;
  }
  *min = *max = points[0];
  for (const auto& p : points) {
    *min = min->cwiseMin(p);
    *max = max->cwiseMax(p);
  }
}

OrganizedPointCloud::OrganizedPointCloud(int w, int h, bool with_normals, bool with_intensity,
                                         bool with_quality)
    : width(w), height(h) {
  const size_t n = static_cast<size_t>(w) * h;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  cloud.points.assign(n, Eigen::Vector3d::Constant(nan));
  if (with_normals) cloud.normals.assign(n, Eigen::Vector3d::Constant(nan));
  if (with_intensity) cloud.intensity.assign(n, 0.f);
  if (with_quality) cloud.quality.assign(n, 0.f);
  valid.assign(n, 0);
}

size_t OrganizedPointCloud::NumValid() const {
  size_t n = 0;
  for (uint8_t v : valid) n += v != 0;
  return n;
}

PointCloud OrganizedPointCloud::Compact() const {
  PointCloud out;
  out.Reserve(NumValid());
  for (size_t i = 0; i < valid.size(); ++i) {
    if (valid[i]) out.PushBackFrom(cloud, i);
  }
  return out;
}

void OrganizedPointCloud::CheckConsistent() const {
  const size_t n = static_cast<size_t>(width) * height;
  if (width < 0 || height < 0 || cloud.size() != n || valid.size() != n) {
    throw Error(util::StrCat("organized point cloud: grid ", width, "x", height, " but ",
                             cloud.size(), " points and ", valid.size(), " validity flags"));
  }
  cloud.CheckConsistent();
}

}  // namespace fringe
