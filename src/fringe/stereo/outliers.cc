#include "fringe/stereo/outliers.h"

#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include "fringe/util/error.h"

namespace fringe::stereo {
namespace {

int Find(std::vector<int>& parent, int i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

}  // namespace

void OutlierOptions::Check() const {
  using util::CheckOption;
  CheckOption(max_slope_factor > 0, "OutlierOptions", "max_slope_factor", max_slope_factor,
              "must be > 0");
  CheckOption(min_neighbours >= 0 && min_neighbours <= 8, "OutlierOptions", "min_neighbours",
              min_neighbours, "must be in [0, 8]");
  CheckOption(min_component_px >= 1, "OutlierOptions", "min_component_px", min_component_px,
              "must be >= 1");
}

const char* ToString(OutlierStatus status) {
  switch (status) {
    case OutlierStatus::kOk:
      return "ok";
    case OutlierStatus::kNoPoints:
      return "no points";
    case OutlierStatus::kAllRemoved:
      return "all points removed";
  }
  return "unknown";
}

std::string OutlierSummary::BriefReport() const {
  return util::StrCat("outliers: ", ToString(status), ok() ? "" : " (" + message + ")", ", ",
                      flying_pixels, " flying pixels, ", small_components, " small components (",
                      component_points, " points) removed, ", kept, " kept");
}

OutlierSummary RemoveOrganizedOutliers(OrganizedPointCloud* grid, double focal_px,
                                       const OutlierOptions& options) {
  options.Check();
  util::CheckOption(focal_px > 0, "RemoveOrganizedOutliers", "focal_px", focal_px, "must be > 0");
  grid->CheckConsistent();
  const int w = grid->width, h = grid->height;
  const auto& pts = grid->cloud.points;
  auto& valid = grid->valid;
  auto connected = [&](size_t i, size_t j, double steps) {
    const double footprint = std::min(pts[i].z(), pts[j].z()) / focal_px;
    const double limit = options.max_slope_factor * footprint * steps;
    return (pts[i] - pts[j]).squaredNorm() <= limit * limit;
  };
  const int dc[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
  const int dr[8] = {-1, -1, -1, 0, 0, 1, 1, 1};
  OutlierSummary s;
  if (grid->NumValid() == 0) {
    s.status = OutlierStatus::kNoPoints;
    s.message = "the cloud has no valid point";
    return s;
  }

  std::vector<uint8_t> flying(valid.size(), 0);
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      const size_t i = grid->index(c, r);
      if (!valid[i]) continue;
      int n = 0;
      for (int k = 0; k < 8; ++k) {
        const int cc = c + dc[k], rr = r + dr[k];
        if (cc < 0 || rr < 0 || cc >= w || rr >= h) continue;
        const size_t j = grid->index(cc, rr);
        n += valid[j] && connected(i, j, (dc[k] && dr[k]) ? std::sqrt(2.0) : 1.0);
      }
      flying[i] = n < options.min_neighbours;
    }
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (size_t i = 0; i < valid.size(); ++i) {
    if (flying[i]) {
      valid[i] = 0;
      grid->cloud.points[i] = Eigen::Vector3d::Constant(nan);
      ++s.flying_pixels;
    }
  }

  std::vector<int> parent(valid.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      const size_t i = grid->index(c, r);
      if (!valid[i]) continue;
      // Forward half of the 8-neighbourhood: right, and the three below.
      const int fc[4] = {1, -1, 0, 1}, fr[4] = {0, 1, 1, 1};
      for (int k = 0; k < 4; ++k) {
        const int cc = c + fc[k], rr = r + fr[k];
        if (cc < 0 || rr >= h || cc >= w) continue;
        const size_t j = grid->index(cc, rr);
        if (valid[j] && connected(i, j, (fc[k] && fr[k]) ? std::sqrt(2.0) : 1.0)) {
          const int a = Find(parent, static_cast<int>(i)), b = Find(parent, static_cast<int>(j));
          if (a != b) parent[std::max(a, b)] = std::min(a, b);
        }
      }
    }
  }
  std::vector<int> size(valid.size(), 0);
  for (size_t i = 0; i < valid.size(); ++i) {
    if (valid[i]) ++size[Find(parent, static_cast<int>(i))];
  }
  for (size_t i = 0; i < valid.size(); ++i) {
    if (!valid[i]) continue;
    const int root = Find(parent, static_cast<int>(i));
    if (size[root] < options.min_component_px) {
      if (static_cast<size_t>(root) == i) ++s.small_components;
      valid[i] = 0;
      grid->cloud.points[i] = Eigen::Vector3d::Constant(nan);
      ++s.component_points;
    } else {
      ++s.kept;
    }
  }
  if (s.kept == 0) {
    s.status = OutlierStatus::kAllRemoved;
    s.message = util::StrCat("all ", s.flying_pixels + s.component_points,
                             " points were flying pixels or in components smaller than ",
                             options.min_component_px, " px");
  }
  return s;
}

}  // namespace fringe::stereo
