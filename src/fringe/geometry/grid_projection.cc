#include "fringe/geometry/grid_projection.h"

#include <tbb/parallel_for.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <vector>

namespace fringe {
namespace {

template <class T>
Eigen::Matrix<T, GridProjection::kMonomials, 1> Monomials(T u, T v) {
  Eigen::Matrix<T, GridProjection::kMonomials, 1> m;
  m << T(1), u, v, u * u, u * v, v * v, u * u * u, u * u * v, u * v * v, v * v * v;
  return m;
}

}  // namespace

GridProjection GridProjection::Fit(const OrganizedPointCloud& g) {
  using Poly = Eigen::Matrix<double, kMonomials, 1>;
  constexpr size_t kMinPoints = 100, kMaxSamples = 40000;
  GridProjection proj;
  proj.width_ = g.width;
  proj.height_ = g.height;
  std::vector<uint32_t> slots;
  for (size_t i = 0; i < g.valid.size(); ++i) {
    if (g.valid[i] && g.cloud.points[i].z() > 0) slots.push_back(static_cast<uint32_t>(i));
  }
  if (slots.size() < kMinPoints) return proj;  // not fitted, error NaN
  const size_t stride = std::max<size_t>(1, slots.size() / kMaxSamples);
  const size_t n = (slots.size() + stride - 1) / stride;
  Eigen::MatrixXd a(n, kMonomials);
  Eigen::MatrixXd b(n, 2);
  const auto width = static_cast<uint32_t>(g.width);
  for (size_t k = 0; k < n; ++k) {
    const uint32_t s = slots[k * stride];
    const Eigen::Vector3d& p = g.cloud.points[s];
    a.row(static_cast<Eigen::Index>(k)) = Monomials(p.x() / p.z(), p.y() / p.z()).transpose();
    b(static_cast<Eigen::Index>(k), 0) = static_cast<double>(s % width);
    b(static_cast<Eigen::Index>(k), 1) = static_cast<double>(s / width);
  }
  const Eigen::MatrixXd x = a.colPivHouseholderQr().solve(b);
  if (!x.allFinite()) {
    proj.fit_error_px_ = std::numeric_limits<double>::infinity();
    return proj;
  }
  const Poly col = x.col(0), row = x.col(1);
  proj.col_poly_ = col.cast<float>();
  proj.row_poly_ = row.cast<float>();
  // The largest error over every valid point (the fit saw a subsample).
  std::vector<double> err(slots.size());
  tbb::parallel_for(size_t{0}, slots.size(), [&](size_t k) {
    const Eigen::Vector3d& p = g.cloud.points[slots[k]];
    const Poly m = Monomials(p.x() / p.z(), p.y() / p.z());
    const double dc = col.dot(m) - static_cast<double>(slots[k] % width);
    const double dr = row.dot(m) - static_cast<double>(slots[k] / width);
    err[k] = std::hypot(dc, dr);
  });
  proj.fit_error_px_ = *std::max_element(err.begin(), err.end());
  proj.fitted_ = std::isfinite(proj.fit_error_px_);
  return proj;
}

bool GridProjection::Project(const Eigen::Vector3f& p_in_sensor, Eigen::Vector2f* col_row) const {
  if (!fitted_ || !(p_in_sensor.z() > 0)) return false;
  const float u = p_in_sensor.x() / p_in_sensor.z(), v = p_in_sensor.y() / p_in_sensor.z();
  const Coefficients m = Monomials(u, v);
  *col_row = Eigen::Vector2f(col_poly_.dot(m), row_poly_.dot(m));
  return col_row->allFinite();
}

bool GridProjection::BoundAt(const Eigen::Vector3f& x, Bound* b) const {
  if (!fitted_ || !(x.z() > 0)) return false;
  const float u = x.x() / x.z(), v = x.y() / x.z();
  const Coefficients m = Monomials(u, v);
  Coefficients mu, mv;  // derivatives of the monomials by u and v
  mu << 0, 1, 0, 2 * u, v, 0, 3 * u * u, 2 * u * v, v * v, 0;
  mv << 0, 0, 1, 0, u, 2 * v, 0, u * u, 2 * u * v, 3 * v * v;
  // The projection's Jacobian and its largest singular value.
  const float a = col_poly_.dot(mu), bu = col_poly_.dot(mv);
  const float c = row_poly_.dot(mu), e = row_poly_.dot(mv);
  const float t = a * a + bu * bu + c * c + e * e, det = a * e - bu * c;
  const float sigma = std::sqrt(0.5f * (t + std::sqrt(std::max(0.f, t * t - 4 * det * det))));
  // A point q = p + d, |d| <= R, has normalized coordinates (u, v) + [I | -(u, v)] d / (z + d_z):
  // the 2x3 matrix's largest singular value is sqrt(1 + u^2 + v^2) (M M^T = I + (u, v)(u, v)^T),
  // so they lie within R sqrt(1 + u^2 + v^2) / (z - R) of p's (the tight bound: the earlier
  // R (1 + |(u, v)|) made the discs at a frame's corners ~1.6 times the area). sigma (+ 5 % for
  // its change across the disc) bounds the distance of q's projection, the fit error that of q's
  // slot from its projection.
  b->col = col_poly_.dot(m);
  b->row = row_poly_.dot(m);
  b->scale = 1.05f * sigma;
  b->norm = std::sqrt(1 + u * u + v * v);
  b->z = x.z();
  b->fit_error_px = static_cast<float>(fit_error_px_);
  return std::isfinite(b->col) && std::isfinite(b->row) && std::isfinite(b->scale);
}

bool GridProjection::DiscOf(const Eigen::Vector3f& x, float radius_mm, Disc* d) const {
  Bound b;
  if (!(x.z() > radius_mm) || !BoundAt(x, &b)) return false;
  d->col = b.col;
  d->row = b.row;
  d->radius_px = b.RadiusPx(radius_mm);
  return std::isfinite(d->radius_px);
}

}  // namespace fringe
