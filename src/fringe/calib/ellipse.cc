#include "fringe/calib/ellipse.h"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>

#include "fringe/util/error.h"

namespace fringe::calib {

namespace {

Eigen::Matrix2d Rot(double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  return r;
}

// Closest point on the axis-aligned ellipse (x/e0)^2 + (y/e1)^2 = 1 (e0 >= e1 > 0) to (y0, y1)
// in the first quadrant (D. Eberly, "Distance from a point to an ellipse"; his root function,
// solved by monotone Newton instead of bisection for speed).
Eigen::Vector2d ClosestFirstQuadrant(double e0, double e1, double y0, double y1) {
  if (y1 > 0) {
    if (y0 > 0) {
      const double z0 = y0 / e0, z1 = y1 / e1;
      const double g = z0 * z0 + z1 * z1 - 1;
      if (g != 0) {
        const double r0 = (e0 / e1) * (e0 / e1);
        const double n0 = r0 * z0;
        // F(s) = (n0 / (s + r0))^2 + (z1 / (s + 1))^2 - 1 is convex and decreasing for
        // s > -1; Newton from below the root (F >= 0 where either term alone is 1) converges
        // monotonically to it.
        double s = std::max(z1 - 1, n0 - r0);
        for (int i = 0; i < 60; ++i) {
          const double a0 = n0 / (s + r0), a1 = z1 / (s + 1);
          const double f = a0 * a0 + a1 * a1 - 1;
          const double df = -2 * (a0 * a0 / (s + r0) + a1 * a1 / (s + 1));
          if (!(df < 0)) break;
          const double step = f / df;
          s -= step;
          if (std::abs(step) <= 1e-15 * (1 + std::abs(s))) break;
        }
        return {r0 * y0 / (s + r0), y1 / (s + 1)};
      }
      return {y0, y1};
    }
    return {0, e1};
  }
  const double numer0 = e0 * y0, denom0 = e0 * e0 - e1 * e1;
  if (numer0 < denom0) {
    const double xde0 = numer0 / denom0;
    return {e0 * xde0, e1 * std::sqrt(std::max(0.0, 1 - xde0 * xde0))};
  }
  return {e0, 0};
}

// Foot point (in the ellipse frame) of p_local on the ellipse with semi-axes a >= b.
Eigen::Vector2d FootPoint(double a, double b, const Eigen::Vector2d& p_local) {
  const Eigen::Vector2d q =
      ClosestFirstQuadrant(a, b, std::abs(p_local.x()), std::abs(p_local.y()));
  return {std::copysign(q.x(), p_local.x()), std::copysign(q.y(), p_local.y())};
}

}  // namespace

void EllipseFitOptions::Check() const {
  using util::CheckOption;
  CheckOption(max_iterations >= 0, "EllipseFitOptions", "max_iterations", max_iterations,
              "must be >= 0");
  CheckOption(outlier_sigma > 0, "EllipseFitOptions", "outlier_sigma", outlier_sigma,
              "must be > 0");
  CheckOption(min_outlier_dist >= 0, "EllipseFitOptions", "min_outlier_dist", min_outlier_dist,
              "must be >= 0");
  CheckOption(outlier_rounds >= 0, "EllipseFitOptions", "outlier_rounds", outlier_rounds,
              "must be >= 0");
}

Eigen::Matrix3d Ellipse::Conic() const {
  const double s = std::sin(angle), c = std::cos(angle);
  const double aa = a * a, bb = b * b;
  const double A = aa * s * s + bb * c * c;
  const double B = 2 * (bb - aa) * s * c;
  const double C = aa * c * c + bb * s * s;
  const double h = centre.x(), k = centre.y();
  const double D = -2 * A * h - B * k;
  const double E = -B * h - 2 * C * k;
  const double F = A * h * h + B * h * k + C * k * k - aa * bb;
  Eigen::Matrix3d m;
  m << A, B / 2, D / 2, B / 2, C, E / 2, D / 2, E / 2, F;
  return m / m.norm();
}

double Ellipse::Area() const { return M_PI * a * b; }

Eigen::Vector2d Ellipse::PointAt(double t) const {
  return centre + Rot(angle) * Eigen::Vector2d(a * std::cos(t), b * std::sin(t));
}

Eigen::Vector2d Ellipse::NormalAt(double t) const {
  return (Rot(angle) * Eigen::Vector2d(b * std::cos(t), a * std::sin(t))).normalized();
}

double Ellipse::SignedDistance(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d local = Rot(angle).transpose() * (p - centre);
  const Eigen::Vector2d foot = FootPoint(a, b, local);
  const double d = (local - foot).norm();
  const double g = (local.x() / a) * (local.x() / a) + (local.y() / b) * (local.y() / b);
  return g >= 1 ? d : -d;
}

std::optional<Eigen::Vector2d> ConicCentre(const Eigen::Matrix3d& conic) {
  const Eigen::Matrix2d m = conic.topLeftCorner<2, 2>();
  const double det = m.determinant();
  if (std::abs(det) < 1e-14 * m.squaredNorm()) return std::nullopt;
  return Eigen::Vector2d(-m.inverse() * conic.topRightCorner<2, 1>());
}

std::optional<Ellipse> EllipseFromConic(const Eigen::Matrix3d& conic_in) {
  Eigen::Matrix3d conic = 0.5 * (conic_in + conic_in.transpose());
  const auto centre = ConicCentre(conic);
  if (!centre) return std::nullopt;
  const Eigen::Vector3d ch(centre->x(), centre->y(), 1.0);
  double f = ch.dot(conic * ch);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(conic.topLeftCorner<2, 2>());
  Eigen::Vector2d lambda = es.eigenvalues();
  if (lambda(0) * lambda(1) <= 0) return std::nullopt;
  if (lambda(0) < 0) {
    lambda = -lambda;
    f = -f;
  }
  if (f >= 0) return std::nullopt;
  // Smaller eigenvalue <-> longer axis.
  Ellipse e;
  e.centre = *centre;
  e.a = std::sqrt(-f / lambda(0));
  e.b = std::sqrt(-f / lambda(1));
  const Eigen::Vector2d major = es.eigenvectors().col(0);
  e.angle = std::atan2(major.y(), major.x());
  if (e.angle > M_PI / 2) e.angle -= M_PI;
  if (e.angle <= -M_PI / 2) e.angle += M_PI;
  if (!std::isfinite(e.a) || !std::isfinite(e.b)) return std::nullopt;
  return e;
}

std::optional<Ellipse> FitEllipseDirect(const std::vector<Eigen::Vector2d>& points) {
  const int n = static_cast<int>(points.size());
  if (n < 5) return std::nullopt;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : points) mean += p;
  mean /= n;
  double rms = 0;
  for (const auto& p : points) rms += (p - mean).squaredNorm();
  rms = std::sqrt(rms / n);
  if (!(rms > 0)) return std::nullopt;
  const double scale = 1.0 / rms;

  Eigen::MatrixXd d1(n, 3), d2(n, 3);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d q = (points[i] - mean) * scale;
    d1.row(i) << q.x() * q.x(), q.x() * q.y(), q.y() * q.y();
    d2.row(i) << q.x(), q.y(), 1.0;
  }
  const Eigen::Matrix3d s1 = d1.transpose() * d1;
  const Eigen::Matrix3d s2 = d1.transpose() * d2;
  const Eigen::Matrix3d s3 = d2.transpose() * d2;
  Eigen::FullPivLU<Eigen::Matrix3d> lu3(s3);
  if (!lu3.isInvertible()) return std::nullopt;
  const Eigen::Matrix3d t = -lu3.solve(s2.transpose());
  const Eigen::Matrix3d m = s1 + s2 * t;
  Eigen::Matrix3d mc;  // C1^-1 * M with the ellipse constraint matrix C1.
  mc.row(0) = m.row(2) / 2;
  mc.row(1) = -m.row(1);
  mc.row(2) = m.row(0) / 2;
  Eigen::EigenSolver<Eigen::Matrix3d> es(mc);
  int best = -1;
  double best_cond = 0;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d v = es.eigenvectors().col(i).real();
    const double cond = 4 * v(0) * v(2) - v(1) * v(1);
    if (cond > best_cond) {
      best_cond = cond;
      best = i;
    }
  }
  if (best < 0) return std::nullopt;
  const Eigen::Vector3d a1 = es.eigenvectors().col(best).real();
  const Eigen::Vector3d a2 = t * a1;
  Eigen::Matrix3d cn;
  cn << a1(0), a1(1) / 2, a2(0) / 2, a1(1) / 2, a1(2), a2(1) / 2, a2(0) / 2, a2(1) / 2, a2(2);
  Eigen::Matrix3d norm;
  norm << scale, 0, -scale * mean.x(), 0, scale, -scale * mean.y(), 0, 0, 1;
  return EllipseFromConic(norm.transpose() * cn * norm);
}

Ellipse RefineEllipse(const std::vector<Eigen::Vector2d>& points, const Ellipse& initial,
                      int max_iterations) {
  const int n = static_cast<int>(points.size());
  using Vec5 = Eigen::Matrix<double, 5, 1>;
  auto to_ellipse = [](const Vec5& x) {
    Ellipse e;
    e.centre = x.head<2>();
    e.a = x(2);
    e.b = x(3);
    e.angle = x(4);
    return e;
  };
  // Residuals d_i = (p_i - X(t_i)) . n_i with X the foot point; by the envelope theorem
  // dd/dparam = -n . dX/dparam at the fixed foot parameter.
  auto evaluate = [&](const Vec5& x, Eigen::VectorXd* r, Eigen::MatrixXd* jac) {
    const double a = std::max(std::abs(x(2)), std::abs(x(3)));
    const double b = std::min(std::abs(x(2)), std::abs(x(3)));
    const bool swapped = std::abs(x(3)) > std::abs(x(2));
    const double phi = swapped ? x(4) + M_PI / 2 : x(4);
    const Eigen::Matrix2d rot = Rot(phi);
    Eigen::Matrix2d drot;
    drot << -std::sin(phi), -std::cos(phi), std::cos(phi), -std::sin(phi);
    double cost = 0;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d local = rot.transpose() * (points[i] - x.head<2>());
      const Eigen::Vector2d foot = FootPoint(a, b, local);
      const double ct = foot.x() / a, st = foot.y() / b;
      Eigen::Vector2d normal_local(b * ct, a * st);
      normal_local.normalize();
      const double d = (local - foot).dot(normal_local);
      if (r) (*r)(i) = d;
      cost += d * d;
      if (jac) {
        const Eigen::Vector2d nw = rot * normal_local;
        Eigen::Matrix<double, 2, 5> dx;
        dx.col(0) << 1, 0;
        dx.col(1) << 0, 1;
        const Eigen::Vector2d da = rot * Eigen::Vector2d(ct, 0);
        const Eigen::Vector2d db = rot * Eigen::Vector2d(0, st);
        dx.col(swapped ? 3 : 2) = da;
        dx.col(swapped ? 2 : 3) = db;
        dx.col(4) = drot * Eigen::Vector2d(a * ct, b * st);
        jac->row(i) = -(nw.transpose() * dx);
      }
    }
    return cost;
  };
  Vec5 x;
  x << initial.centre, initial.a, initial.b, initial.angle;
  Eigen::VectorXd r(n);
  Eigen::MatrixXd jac(n, 5);
  double cost = evaluate(x, &r, &jac);
  double mu = 1e-3;
  for (int it = 0; it < max_iterations; ++it) {
    const Eigen::Matrix<double, 5, 5> jtj = jac.transpose() * jac;
    const Vec5 g = jac.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 8; ++tries) {
      Eigen::Matrix<double, 5, 5> h = jtj;
      h.diagonal() += mu * jtj.diagonal().cwiseMax(1e-12);
      const Vec5 step = h.ldlt().solve(-g);
      const Vec5 xn = x + step;
      if (!(std::abs(xn(2)) > 0 && std::abs(xn(3)) > 0) || !xn.allFinite()) {
        mu *= 10;
        continue;
      }
      const double cn = evaluate(xn, nullptr, nullptr);
      if (cn < cost) {
        x = xn;
        const double rel = (cost - cn) / std::max(cost, 1e-300);
        cost = evaluate(x, &r, &jac);
        mu = std::max(mu * 0.3, 1e-9);
        improved = rel > 1e-12 && step.norm() > 1e-12;
        break;
      }
      mu *= 10;
    }
    if (!improved) break;
  }
  Ellipse e = to_ellipse(x);
  e.a = std::abs(e.a);
  e.b = std::abs(e.b);
  if (e.b > e.a) {
    std::swap(e.a, e.b);
    e.angle += M_PI / 2;
  }
  e.angle = std::remainder(e.angle, M_PI);
  if (e.angle <= -M_PI / 2) e.angle += M_PI;
  return e;
}

std::optional<EllipseFitResult> FitEllipse(const std::vector<Eigen::Vector2d>& points,
                                           const EllipseFitOptions& options) {
  std::vector<Eigen::Vector2d> used = points;
  auto ellipse = FitEllipseDirect(used);
  if (!ellipse) return std::nullopt;
  EllipseFitResult result;
  for (int round = 0;; ++round) {
    if (options.max_iterations > 0)
      *ellipse = RefineEllipse(used, *ellipse, options.max_iterations);
    double ss = 0;
    for (const auto& p : used) ss += std::pow(ellipse->SignedDistance(p), 2);
    const double rms = std::sqrt(ss / used.size());
    if (round >= options.outlier_rounds) break;
    const double limit = std::max(options.outlier_sigma * rms, options.min_outlier_dist);
    std::vector<Eigen::Vector2d> kept;
    kept.reserve(used.size());
    for (const auto& p : points) {
      if (std::abs(ellipse->SignedDistance(p)) <= limit) kept.push_back(p);
    }
    if (kept.size() == used.size() || kept.size() < 5) break;
    used = std::move(kept);
  }
  result.ellipse = *ellipse;
  double ss = 0, mx = 0;
  for (const auto& p : used) {
    const double d = std::abs(ellipse->SignedDistance(p));
    ss += d * d;
    mx = std::max(mx, d);
  }
  result.num_points = static_cast<int>(used.size());
  result.num_outliers = static_cast<int>(points.size() - used.size());
  result.rms_residual = std::sqrt(ss / std::max<size_t>(1, used.size()));
  result.max_residual = mx;
  return result;
}

std::optional<Eigen::Vector2d> ConcentricCentre(const Eigen::Matrix3d& conic1,
                                                const Eigen::Matrix3d& conic2) {
  // Condition the problem: coordinates centred on the first ellipse and scaled by its size
  // (pixel coordinates in the hundreds make the pencil's eigenproblem ill-conditioned).
  const auto e1 = EllipseFromConic(conic1);
  if (!e1) return std::nullopt;
  const double s = std::sqrt(e1->a * e1->b);
  Eigen::Matrix3d t_inv;  // pixel = t_inv * normalized
  t_inv << s, 0, e1->centre.x(), 0, s, e1->centre.y(), 0, 0, 1;
  Eigen::Matrix3d c1 = t_inv.transpose() * conic1 * t_inv;
  Eigen::Matrix3d c2 = t_inv.transpose() * conic2 * t_inv;
  c1 /= c1.norm();
  c2 /= c2.norm();
  Eigen::FullPivLU<Eigen::Matrix3d> lu2(c2);
  if (!lu2.isInvertible()) return std::nullopt;
  // det(C1 - lambda C2) = 0  <=>  lambda eigenvalue of C2^-1 C1. Two roots coincide (the
  // repeated line); with noise they split slightly, possibly into a complex pair.
  Eigen::EigenSolver<Eigen::Matrix3d> es(lu2.solve(c1), false);
  const Eigen::Vector3cd ev = es.eigenvalues();
  int simple = -1;
  double best_gap = -1;
  for (int i = 0; i < 3; ++i) {
    double gap = std::numeric_limits<double>::infinity();
    for (int j = 0; j < 3; ++j) {
      if (j != i) gap = std::min(gap, std::abs(ev(i) - ev(j)));
    }
    if (gap > best_gap) {
      best_gap = gap;
      simple = i;
    }
  }
  int p = -1, q = -1;
  for (int i = 0; i < 3; ++i) {
    if (i == simple) continue;
    (p < 0 ? p : q) = i;
  }
  const double pair_gap = std::abs(ev(p) - ev(q));
  const double scale = ev.cwiseAbs().maxCoeff();
  if (!(best_gap > 4 * pair_gap) || !(best_gap > 1e-6 * scale)) {
    return std::nullopt;  // no clear double root
  }
  const double lambda = 0.5 * (ev(p) + ev(q)).real();
  // C1 - lambda C2 = l l^T up to scale: its dominant eigenvector is the vanishing line.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> ds(c1 - lambda * c2);
  int k = 0;
  for (int i = 1; i < 3; ++i) {
    if (std::abs(ds.eigenvalues()(i)) > std::abs(ds.eigenvalues()(k))) k = i;
  }
  const Eigen::Vector3d line = ds.eigenvectors().col(k);
  // Pole of the vanishing line w.r.t. each conic; both are the centre's image.
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (const Eigen::Matrix3d* c : {&c1, &c2}) {
    const Eigen::Vector3d pole = Eigen::FullPivLU<Eigen::Matrix3d>(*c).solve(line);
    if (std::abs(pole.z()) < 1e-300) return std::nullopt;
    sum += pole.hnormalized();
  }
  const Eigen::Vector2d centre = (t_inv * (0.5 * sum).homogeneous()).hnormalized();
  if (!centre.allFinite()) return std::nullopt;
  return centre;
}

std::optional<Eigen::Vector2d> RingCentre(const Ellipse& outer, const Ellipse& inner,
                                          double radius_ratio, double max_disagreement_px) {
  const auto c = ConcentricCentre(outer.Conic(), inner.Conic());
  if (!c) return std::nullopt;
  const double q = radius_ratio * radius_ratio;
  const Eigen::Vector2d extrapolated = (inner.centre - q * outer.centre) / (1 - q);
  const double spread = (outer.centre - inner.centre).norm();
  if ((*c - extrapolated).norm() > max_disagreement_px + 0.5 * spread) return std::nullopt;
  return c;
}

Eigen::Matrix3d ProjectCircle(const Eigen::Matrix3d& image_from_plane,
                              const Eigen::Vector2d& centre, double radius) {
  Eigen::Matrix3d circle;
  circle << 1, 0, -centre.x(), 0, 1, -centre.y(), -centre.x(), -centre.y(),
      centre.squaredNorm() - radius * radius;
  const Eigen::Matrix3d h_inv = image_from_plane.inverse();
  const Eigen::Matrix3d c = h_inv.transpose() * circle * h_inv;
  return c / c.norm();
}

}  // namespace fringe::calib
