#include "fringe/geometry/normals.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe {
namespace {

constexpr int kChannels = 10;  // n, x, y, z, xx, xy, xz, yy, yz, zz

// Unit eigenvector of the smallest eigenvalue of a symmetric positive semi-definite 3x3 matrix,
// when that eigenvalue is well separated from the middle one (the usual case on a surface:
// (middle - smallest) > kSeparation * largest); false otherwise, and the caller uses Eigen's
// solver. The smallest root of the characteristic polynomial by Newton's method from 0 (left of
// it for a PSD matrix, where the cubic is increasing and concave: the iterates rise to the root
// without overshooting), the vector as the largest cross product of two rows of
// (cov - lambda I). About 4x faster than Eigen's closed form (acos / atan2, cos, sin per point).
bool SmallestEigenvector(const Eigen::Matrix3d& cov, Eigen::Vector3d* vector) {
  constexpr double kSeparation = 1e-6;
  const double a = cov(0, 0), b = cov(1, 1), c = cov(2, 2);
  const double d = cov(0, 1), e = cov(0, 2), f = cov(1, 2);
  // det(lambda I - cov) = lambda^3 - c2 lambda^2 + c1 lambda - c0.
  const double c2 = a + b + c;
  const double c1 = a * b + a * c + b * c - d * d - e * e - f * f;
  const double c0 = a * b * c + 2 * d * e * f - a * f * f - b * e * e - c * d * d;
  if (!(c2 > 0)) return false;
  double lambda = 0;
  bool converged = false;
  for (int it = 0; it < 20; ++it) {
    const double p = ((lambda - c2) * lambda + c1) * lambda - c0;
    const double dp = (3 * lambda - 2 * c2) * lambda + c1;
    if (!(dp > 0)) break;
    const double step = p / dp;
    lambda -= step;
    if (std::abs(step) <= 1e-15 * c2) {
      converged = true;
      break;
    }
  }
  if (!converged) return false;
  // The other two eigenvalues: sum s = c2 - lambda, product q = c1 - lambda * s; the middle one
  // without cancellation.
  const double sum = c2 - lambda, product = c1 - lambda * sum;
  const double disc = std::max(sum * sum - 4 * product, 0.0);
  const double middle = 2 * product / (sum + std::sqrt(disc));
  if (!(middle - lambda > kSeparation * c2)) return false;
  const Eigen::Vector3d r0(a - lambda, d, e), r1(d, b - lambda, f), r2(e, f, c - lambda);
  const Eigen::Vector3d x01 = r0.cross(r1), x02 = r0.cross(r2), x12 = r1.cross(r2);
  const double n01 = x01.squaredNorm(), n02 = x02.squaredNorm(), n12 = x12.squaredNorm();
  const Eigen::Vector3d& best = n01 >= n02 ? (n01 >= n12 ? x01 : x12) : (n02 >= n12 ? x02 : x12);
  const double norm = std::sqrt(std::max({n01, n02, n12}));
  if (!(norm > 0)) return false;
  *vector = best / norm;
  return true;
}

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
  Eigen::Vector3d nv;
  if (!SmallestEigenvector(cov, &nv)) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(cov);
    // A line of points (rank 1) has no defined normal.
    if (!(eig.eigenvalues()(1) > 1e-9 * eig.eigenvalues()(2))) return false;
    nv = eig.eigenvectors().col(0).normalized();
  }
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

  // Centre the coordinates on one valid point so the window sums keep their precision.
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
  // One byte per pixel (distances are clamped at the window radius, <= 20): the edge flags become
  // the per-row distances in place, then `dist` holds the final distances.
  const int max_rad = options.window_radius_px;
  std::vector<uint8_t> row_dist(pts.size(), 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      uint8_t* edge = &row_dist[grid->index(0, r)];
      for (int c = 0; c < w; ++c) {
        const size_t i = grid->index(c, r);
        if (!valid[i]) continue;
        const int dc[4] = {-1, 1, 0, 0}, dr[4] = {0, 0, -1, 1};
        for (int k = 0; k < 4; ++k) {
          const int cc = c + dc[k], rr = r + dr[k];
          // Windows are kept symmetric about their point (a one-sided window on a curved
          // surface tilts the normal): the image border and missing pixels count as edges too.
          if (cc < 0 || rr < 0 || cc >= w || rr >= h) {
            edge[c] = 1;
            continue;
          }
          const size_t j = grid->index(cc, rr);
          if (!valid[j] || !same_surface(i, j)) edge[c] = 1;
        }
      }
      // Chessboard distance to the nearest edge pixel, clamped at the window radius (only
      // min(radius, distance) is used). L-infinity distance is separable: per row the distance
      // along the row (here, in place of the edge flags: 0 exactly at edge pixels), then per
      // pixel the minimum over rows within the radius of max(row offset, that). Both passes run
      // in parallel (a two-pass raster transform is serial).
      int last = max_rad;
      for (int c = 0; c < w; ++c) {
        last = edge[c] ? 0 : std::min(last + 1, max_rad);
        edge[c] = static_cast<uint8_t>(last);
      }
      last = max_rad;
      for (int c = w - 1; c >= 0; --c) {
        last = edge[c] == 0 ? 0 : std::min(last + 1, max_rad);
        edge[c] = static_cast<uint8_t>(std::min<int>(edge[c], last));
      }
    }
  });
  std::vector<uint8_t> dist(pts.size());
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      uint8_t* d = &dist[grid->index(0, r)];
      std::copy_n(&row_dist[grid->index(0, r)], w, d);
      for (int k = 1; k <= max_rad; ++k) {
        for (const int rr : {r - k, r + k}) {
          if (rr < 0 || rr >= h) continue;
          const uint8_t* o = &row_dist[grid->index(0, rr)];
          for (int c = 0; c < w; ++c) d[c] = std::min<uint8_t>(d[c], std::max<uint8_t>(k, o[c]));
        }
      }
    }
  });

  // Window sums per band of rows, from small per-thread buffers (no image-sized integral image:
  // 100 MB of fresh pages per call cost more than the sums). For a row r: the products
  // (n, x, y, z, xx, ...) of every pixel of rows r - R .. r + R (a ring of 2R + 1 rows, each row
  // computed once per band), their column sums over rows r - k .. r + k for every radius
  // k = 1 .. R, and for each point the sum of its radius' column sums over columns c - k .. c + k.
  // The sums are of coordinates centred on `shift`; each window sums at most (2R + 1)^2 terms
  // (the integral image's sums ran over the whole image, so these lose less to rounding).
  std::vector<GridNormalSummary> per_row(h);
  const size_t row_len = static_cast<size_t>(w) * kChannels;
  const int ring_rows = 2 * max_rad + 1;
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 32), [&](const auto& rows) {
    // Per thread, kept between calls (a fresh buffer's pages cost more than its sums): the ring
    // of product rows, then the column sums of radius 1 .. R.
    static thread_local std::vector<double> scratch;
    scratch.resize(row_len * (ring_rows + max_rad));
    double* ring = scratch.data();
    double* column_sums = ring + row_len * ring_rows;
    std::vector<int> ring_row(ring_rows, -1);  // image row held by each ring slot
    auto products = [&](int rr) -> const double* {
      double* out = ring + row_len * (rr % ring_rows);
      if (ring_row[rr % ring_rows] == rr) return out;
      ring_row[rr % ring_rows] = rr;
      for (int c = 0; c < w; ++c) {
        double* cell = out + static_cast<size_t>(c) * kChannels;
        const size_t i = grid->index(c, rr);
        std::fill(cell, cell + kChannels, 0.0);
        if (valid[i]) Accumulate(cell, pts[i] - shift);
      }
      return out;
    };
    double s[kChannels];
    std::vector<std::pair<int, int>> spans;  // column ranges [begin, end) of this row's windows
    for (int r = rows.begin(); r < rows.end(); ++r) {
      GridNormalSummary& rs = per_row[r];
      // Column sums of radius k = previous radius' + rows r - k and r + k (rows outside the
      // image add nothing, as the integral image clipped them).
      // Only over the columns some window of this row reads (spans [c - rad, c + rad] of its
      // points with rad >= 1, merged): the same sums, none computed for holes and background.
      spans.clear();
      for (int c = 0; c < w; ++c) {
        const size_t i = grid->index(c, r);
        if (!valid[i]) continue;
        const int rad = std::min<int>(max_rad, dist[i]);
        if (rad < 1) continue;
        const int c0 = std::max(c - rad, 0), c1 = std::min(c + rad + 1, w);
        if (!spans.empty() && c0 <= spans.back().second) {
          spans.back().second = std::max(spans.back().second, c1);
        } else {
          spans.emplace_back(c0, c1);
        }
      }
      if (!spans.empty()) {
        const double* centre = products(r);
        for (int k = 1; k <= max_rad; ++k) {
          double* sum = column_sums + row_len * (k - 1);
          const double* prev = k == 1 ? centre : sum - row_len;
          const double* add[2] = {nullptr, nullptr};
          int num_add = 0;
          for (const int rr : {r - k, r + k}) {
            if (rr >= 0 && rr < h) add[num_add++] = products(rr);
          }
          for (const auto& [c0, c1] : spans) {
            const size_t e0 = static_cast<size_t>(c0) * kChannels;
            const size_t e1 = static_cast<size_t>(c1) * kChannels;
            std::copy(prev + e0, prev + e1, sum + e0);
            for (int a = 0; a < num_add; ++a) {
              for (size_t e = e0; e < e1; ++e) sum[e] += add[a][e];
            }
          }
        }
      }
      for (int c = 0; c < w; ++c) {
        const size_t i = grid->index(c, r);
        if (!valid[i]) {
          normals[i] = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
          continue;
        }
        const Eigen::Vector3d q = pts[i] - shift;
        const int rad = std::min<int>(options.window_radius_px, dist[i]);
        bool ok;
        if (rad >= 1) {
          const int c0 = std::max(c - rad, 0), c1 = std::min(c + rad + 1, w);
          const double* sum = column_sums + row_len * (rad - 1);
          std::fill(s, s + kChannels, 0.0);
          for (int c2 = c0; c2 < c1; ++c2) {
            const double* cell = sum + static_cast<size_t>(c2) * kChannels;
            for (int k = 0; k < kChannels; ++k) s[k] += cell[k];
          }
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
