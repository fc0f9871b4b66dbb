#include "fringe/stereo/outliers.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "fringe/util/error.h"

namespace fringe::stereo {
namespace {

constexpr int kForward = 4;  // links to the forward half of the 8-neighbourhood

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
  auto& pts = grid->cloud.points;
  auto& valid = grid->valid;
  auto connected = [&](size_t i, size_t j, double steps) {
    const double footprint = std::min(pts[i].z(), pts[j].z()) / focal_px;
    const double limit = options.max_slope_factor * footprint * steps;
    return (pts[i] - pts[j]).squaredNorm() <= limit * limit;
  };
  OutlierSummary s;
  if (grid->NumValid() == 0) {
    s.status = OutlierStatus::kNoPoints;
    s.message = "the cloud has no valid point";
    return s;
  }

  // Rows in parallel throughout; every result is the sequential definition's (the connected
  // components are those of the same links whatever order they are joined in).
  // 1. Each pixel's links to its forward half of the 8-neighbourhood (right, and the three below),
  //    one bit each: connected() is symmetric, so the backward half is the neighbours' forward
  //    bits and every pair is tested once.
  const int fc[kForward] = {1, -1, 0, 1}, fr[kForward] = {0, 1, 1, 1};
  const double diagonal = std::sqrt(2.0);
  std::vector<uint8_t> links(valid.size(), 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      for (int c = 0; c < w; ++c) {
        const size_t i = grid->index(c, r);
        if (!valid[i]) continue;
        uint8_t bits = 0;
        for (int k = 0; k < kForward; ++k) {
          const int cc = c + fc[k], rr = r + fr[k];
          if (cc < 0 || rr >= h || cc >= w) continue;
          const size_t j = grid->index(cc, rr);
          if (valid[j] && connected(i, j, (fc[k] && fr[k]) ? diagonal : 1.0)) bits |= 1 << k;
        }
        links[i] = bits;
      }
    }
  });
  // 2. Flying pixels: fewer connected 8-neighbours than min_neighbours (links to the left, up-
  //    right, up and up-left neighbours are their right, down-left, down and down-right bits).
  //    Marked in `flying`, then removed once every row is judged.
  std::vector<uint8_t> flying(valid.size(), 0);
  std::vector<int> row_flying(h, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      for (int c = 0; c < w; ++c) {
        const size_t i = grid->index(c, r);
        if (!valid[i]) continue;
        int n = 0;
        for (int k = 0; k < kForward; ++k) n += (links[i] >> k) & 1;
        if (c > 0) n += links[i - 1] & 1;  // left: its right
        if (r > 0) {
          const size_t up = i - static_cast<size_t>(w);
          if (c + 1 < w) n += (links[up + 1] >> 1) & 1;  // up-right: its down-left
          n += (links[up] >> 2) & 1;                     // up: its down
          if (c > 0) n += (links[up - 1] >> 3) & 1;      // up-left: its down-right
        }
        if (n < options.min_neighbours) {
          flying[i] = 1;
          ++row_flying[r];
        }
      }
    }
  });
  const double nan = std::numeric_limits<double>::quiet_NaN();
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (size_t i = grid->index(0, rows.begin()); i < grid->index(0, rows.end()); ++i) {
      if (flying[i]) {
        valid[i] = 0;
        pts[i] = Eigen::Vector3d::Constant(nan);
      }
    }
  });
  for (int n : row_flying) s.flying_pixels += n;

  // 3. Connected components (union-find, each root the smallest index of its component) over
  //    the links between remaining points: bands of rows in parallel (a band's unions stay in
  //    the band), then the links across band boundaries, then every pixel's root.
  std::vector<int> parent(valid.size());
  constexpr int kBandRows = 32;
  const int bands = (h + kBandRows - 1) / kBandRows;
  auto link_pixel = [&](int c, int r, int row_end) {
    const size_t i = grid->index(c, r);
    if (!valid[i]) return;
    for (int k = 0; k < kForward; ++k) {
      if (!((links[i] >> k) & 1)) continue;
      const int rr = r + fr[k];
      if (rr >= row_end) continue;
      const size_t j = grid->index(c + fc[k], rr);
      if (!valid[j]) continue;
      const int a = Find(parent, static_cast<int>(i)), b = Find(parent, static_cast<int>(j));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  };
  tbb::parallel_for(0, bands, [&](int band) {
    const int r0 = band * kBandRows, r1 = std::min(h, r0 + kBandRows);
    const size_t i0 = grid->index(0, r0), i1 = grid->index(0, r1);
    for (size_t i = i0; i < i1; ++i) parent[i] = static_cast<int>(i);
    for (int r = r0; r < r1; ++r) {
      for (int c = 0; c < w; ++c) link_pixel(c, r, r1);
    }
  });
  for (int band = 1; band < bands; ++band) {
    const int r = band * kBandRows - 1;
    for (int c = 0; c < w; ++c) link_pixel(c, r, r + 2);
  }
  // Roots without path compression (read only, in parallel), then the sizes in `size`.
  std::vector<int> root(valid.size(), -1);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (size_t i = grid->index(0, rows.begin()); i < grid->index(0, rows.end()); ++i) {
      if (!valid[i]) continue;
      int k = static_cast<int>(i);
      while (parent[k] != k) k = parent[k];
      root[i] = k;
    }
  });
  std::vector<int>& size = parent;  // parent is no longer needed
  std::fill(size.begin(), size.end(), 0);
  for (size_t i = 0; i < valid.size(); ++i) {
    if (root[i] >= 0) ++size[root[i]];
  }
  std::vector<OutlierSummary> per_row(h);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      OutlierSummary& rs = per_row[r];
      for (size_t i = grid->index(0, r); i < grid->index(0, r + 1); ++i) {
        if (root[i] < 0) continue;
        if (size[root[i]] < options.min_component_px) {
          if (static_cast<size_t>(root[i]) == i) ++rs.small_components;
          valid[i] = 0;
          pts[i] = Eigen::Vector3d::Constant(nan);
          ++rs.component_points;
        } else {
          ++rs.kept;
        }
      }
    }
  });
  for (const OutlierSummary& rs : per_row) {
    s.small_components += rs.small_components;
    s.component_points += rs.component_points;
    s.kept += rs.kept;
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
