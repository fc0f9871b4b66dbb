#include "fringe/geometry/normals.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe {
namespace {

constexpr int kChannels = 10;  // n, x, y, z, xx, xy, xz, yy, yz, zz

// Normal of the points summed in s (channels as above), oriented toward the origin; false when
// the points do not define a plane.
bool NormalFromSums(const double* s, const Eigen::Vector3d& origin_shift, const Eigen::Vector3d& p,
                    int min_points, Eigen::Vector3d* normal) {
  const double n = s[0];
  if (n < min_points) return false;
  const Eigen::Vector3d mean(s[1] / n, s[2] / n, s[3] / n);
  Eigen::Matrix3d cov;
  cov(0, 0) = s[4] / n - mean.x() * mean.x();
  cov(0, 1) = cov(1, 0) = s[5] / n - mean.x() * mean.y();
  cov(0, 2) = cov(2, 0) = s[6] / n - mean.x() * mean.z();
  cov(1, 1) = s[7] / n - mean.y() * mean.y();
  cov(1, 2) = cov(2, 1) = s[8] / n - mean.y() * mean.z();
  cov(2, 2) = s[9] / n - mean.z() * mean.z();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(cov);
  // A line of points (rank 1) has no defined normal.
  if (!(eig.eigenvalues()(1) > 1e-9 * eig.eigenvalues()(2))) return false;
  Eigen::Vector3d nv = eig.eigenvectors().col(0).normalized();
  if (nv.dot(p + origin_shift) > 0) nv = -nv;
  *normal = nv;
  return true;
}

void Accumulate(double* s, const Eigen::Vector3d& q) {
  s[0] += 1;
  s[1] += q.x();
  s[2] += q.y();
  s[3] += q.z();
  s[4] += q.x() * q.x();
  s[5] += q.x() * q.y();
  s[6] += q.x() * q.z();
  s[7] += q.y() * q.y();
  s[8] += q.y() * q.z();
  s[9] += q.z() * q.z();
}

}  // namespace

void GridNormalOptions::Check() const {
  using util::CheckOption;
  CheckOption(window_radius_px >= 1 && window_radius_px <= 20, "GridNormalOptions",
              "window_radius_px", window_radius_px, "must be in [1, 20]");
  CheckOption(max_depth_jump_mm > 0, "GridNormalOptions", "max_depth_jump_mm", max_depth_jump_mm,
              "must be > 0");
  CheckOption(relative_depth_jump >= 0, "GridNormalOptions", "relative_depth_jump",
              relative_depth_jump, "must be >= 0");
  CheckOption(min_points >= 3 && min_points <= 1000, "GridNormalOptions", "min_points", min_points,
              "must be in [3, 1000]");
}

const char* ToString(GridNormalStatus status) {
  switch (status) {
    case GridNormalStatus::kOk:
      return "ok";
    case GridNormalStatus::kNoPoints:
      return "no points";
    case GridNormalStatus::kNoNormals:
      return "no normals";
  }
  return "unknown";
}

std::string GridNormalSummary::BriefReport() const {
  return util::StrCat("grid normals: ", ToString(status), ok() ? "" : " (" + message + ")", ", ",
                      normals, " normals, ", missing, " points without, ", edge_points,
                      " edge points, ", time_s, " s");
}

GridNormalSummary EstimateGridNormals(OrganizedPointCloud* grid, const GridNormalOptions& options) {
  options.Check();
  grid->CheckConsistent();
  util::Timer timer;
  const int w = grid->width, h = grid->height;
  const auto& pts = grid->cloud.points;
  const auto& valid = grid->valid;
  auto& normals = grid->cloud.normals;
  // Every entry is written by the final pass (NaN where there is no normal), in parallel.
  normals.resize(pts.size());
  GridNormalSummary summary;
  if (w == 0 || h == 0) return summary;

  // Centre the coordinates on one valid point so the integral sums keep their precision.
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < pts.size(); ++i) {
    if (valid[i]) {
      shift = pts[i];
      break;
    }
  }
  auto same_surface = [&](size_t a, size_t b, double relax = 1.0) {
    const double za = pts[a].z(), zb = pts[b].z();
    return std::abs(za - zb) <=
           relax * (options.max_depth_jump_mm + options.relative_depth_jump * std::min(za, zb));
  };

  // Edge pixels (next to a depth jump), and each pixel's chessboard distance to the nearest one.
  std::vector<uint8_t> edge(pts.size(), 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      for (int c = 0; c < w; ++c) {
        const size_t i = grid->index(c, r);
        if (!valid[i]) continue;
        const int dc[4] = {-1, 1, 0, 0}, dr[4] = {0, 0, -1, 1};
        for (int k = 0; k < 4; ++k) {
          const int cc = c + dc[k], rr = r + dr[k];
          // Windows are kept symmetric about their point (a one-sided window on a curved
          // surface tilts the normal): the image border and missing pixels count as edges too.
          if (cc < 0 || rr < 0 || cc >= w || rr >= h) {
            edge[i] = 1;
            continue;
          }
          const size_t j = grid->index(cc, rr);
          if (!valid[j] || !same_surface(i, j)) edge[i] = 1;
        }
      }
    }
  });
  // Chessboard distance to the nearest edge pixel, clamped at the window radius (only
  // min(radius, distance) is used). L-infinity distance is separable: per row the distance along
  // the row, then per pixel the minimum over rows within the radius of max(row offset, that).
  // Both passes run in parallel (a two-pass raster transform is serial).
  const int max_rad = options.window_radius_px;
  std::vector<int> row_dist(pts.size());
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      int* d = &row_dist[grid->index(0, r)];
      const uint8_t* e = &edge[grid->index(0, r)];
      int last = max_rad;
      for (int c = 0; c < w; ++c) {
        last = e[c] ? 0 : std::min(last + 1, max_rad);
        d[c] = last;
      }
      last = max_rad;
      for (int c = w - 1; c >= 0; --c) {
        last = e[c] ? 0 : std::min(last + 1, max_rad);
        d[c] = std::min(d[c], last);
      }
    }
  });
  std::vector<int> dist(pts.size());
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      int* d = &dist[grid->index(0, r)];
      std::copy_n(&row_dist[grid->index(0, r)], w, d);
      for (int k = 1; k <= max_rad; ++k) {
        for (const int rr : {r - k, r + k}) {
          if (rr < 0 || rr >= h) continue;
          const int* o = &row_dist[grid->index(0, rr)];
          for (int c = 0; c < w; ++c) d[c] = std::min(d[c], std::max(k, o[c]));
        }
      }
    }
  });

  // Integral images (h+1) x (w+1) x kChannels: rows in parallel, then columns in parallel.
  // Left uninitialized (no serial zero fill of ~100 MB): the parallel row pass writes every
  // element, so the pages are also first touched in parallel.
  const size_t stride = static_cast<size_t>(w + 1) * kChannels;
  std::unique_ptr<double[]> integral(new double[static_cast<size_t>(h + 1) * stride]);
  std::fill(&integral[0], &integral[0] + stride, 0.0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      double* row = &integral[(r + 1) * stride];
      std::fill(row, row + kChannels, 0.0);
      for (int c = 0; c < w; ++c) {
        double* cell = row + (c + 1) * kChannels;
        std::copy(cell - kChannels, cell, cell);
        const size_t i = grid->index(c, r);
        if (valid[i]) Accumulate(cell, pts[i] - shift);
      }
    }
  });
  // Column sums row by row over contiguous blocks of the row (cache friendly).
  tbb::parallel_for(tbb::blocked_range<int>(0, (w + 1) * kChannels, 1024), [&](const auto& cols) {
    for (int r = 1; r <= h; ++r) {
      double* row = &integral[r * stride];
      const double* above = row - stride;
      for (int k = cols.begin(); k < cols.end(); ++k) row[k] += above[k];
    }
  });

  std::vector<GridNormalSummary> per_row(h);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    double s[kChannels];
    for (int r = rows.begin(); r < rows.end(); ++r) {
      GridNormalSummary& rs = per_row[r];
      for (int c = 0; c < w; ++c) {
        const size_t i = grid->index(c, r);
        if (!valid[i]) {
          normals[i] = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
          continue;
        }
        const Eigen::Vector3d q = pts[i] - shift;
        const int rad = std::min(options.window_radius_px, dist[i]);
        bool ok;
        if (rad >= 1) {
          const int c0 = std::max(c - rad, 0), c1 = std::min(c + rad + 1, w);
          const int r0 = std::max(r - rad, 0), r1 = std::min(r + rad + 1, h);
          const double* a = &integral[r0 * stride + c0 * kChannels];
          const double* b = &integral[r0 * stride + c1 * kChannels];
          const double* cc = &integral[r1 * stride + c0 * kChannels];
          const double* d = &integral[r1 * stride + c1 * kChannels];
          for (int k = 0; k < kChannels; ++k) s[k] = d[k] - b[k] - cc[k] + a[k];
          // The sums are of centred coordinates: re-centre on this point for the covariance.
          ok = NormalFromSums(s, shift, q, options.min_points, &normals[i]);
        } else {
          ++rs.edge_points;
          // Keep the neighbours on this point's surface; on a steep surface (grazing view) even
          // true neighbours jump in depth, so the threshold is relaxed until enough remain.
          const int er = std::min(options.window_radius_px, 2);
          ok = false;
          for (double relax = 1; relax <= 8 && !ok; relax *= 2) {
            std::fill(s, s + kChannels, 0.0);
            for (int rr = std::max(r - er, 0); rr <= std::min(r + er, h - 1); ++rr) {
              for (int c2 = std::max(c - er, 0); c2 <= std::min(c + er, w - 1); ++c2) {
                const size_t j = grid->index(c2, rr);
                if (valid[j] && same_surface(i, j, relax)) Accumulate(s, pts[j] - pts[i]);
              }
            }
            ok =
                NormalFromSums(s, pts[i], Eigen::Vector3d::Zero(), options.min_points, &normals[i]);
          }
        }
        if (ok) {
          ++rs.normals;
        } else {
          ++rs.missing;
          normals[i] = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
        }
      }
    }
  });
  for (const auto& rs : per_row) {
    summary.normals += rs.normals;
    summary.missing += rs.missing;
    summary.edge_points += rs.edge_points;
  }
  if (summary.normals == 0) {
    const bool any = summary.missing > 0;
    summary.status = any ? GridNormalStatus::kNoNormals : GridNormalStatus::kNoPoints;
    summary.message = any ? util::StrCat("none of the ", summary.missing, " points has ",
                                         options.min_points, " usable neighbours")
                          : "the cloud has no valid point";
  }
  summary.time_s = timer.ElapsedSeconds();
  return summary;
}

}  // namespace fringe
