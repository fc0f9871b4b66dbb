#include "fringe/pipeline/drift.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "fringe/util/error.h"
#include "fringe/util/format.h"

namespace fringe::pipeline {
namespace {

using util::FigureOrNull;
using util::Fixed;
using util::StrCat;

}  // namespace

void DriftOptions::Check() const {
  using util::CheckOption;
  const char* o = "DriftOptions";
  CheckOption(max_epipolar_systematic_px > 0, o, "max_epipolar_systematic_px",
              max_epipolar_systematic_px, "must be > 0");
  CheckOption(min_markers >= 2, o, "min_markers", min_markers, "must be >= 2");
  CheckOption(min_epipolar_significance > 0, o, "min_epipolar_significance",
              min_epipolar_significance, "must be > 0");
  CheckOption(max_projector_bias_px > 0, o, "max_projector_bias_px", max_projector_bias_px,
              "must be > 0");
  CheckOption(max_projector_systematic_px > 0, o, "max_projector_systematic_px",
              max_projector_systematic_px, "must be > 0");
  CheckOption(min_projector_points >= 1, o, "min_projector_points", min_projector_points,
              "must be >= 1");
  CheckOption(max_two_direction_rms_px > 0, o, "max_two_direction_rms_px", max_two_direction_rms_px,
              "must be > 0");
  CheckOption(max_samples >= 100, o, "max_samples", max_samples, "must be >= 100");
}

nlohmann::json ToJson(const ViewDrift& s) {
  return {{"checked", s.checked},
          {"drift", s.drift},
          {"evidence", s.evidence},
          {"message", s.message},
          {"epipolar_rms_px", FigureOrNull(s.epipolar_rms_px)},
          {"epipolar_mean_px", FigureOrNull(s.epipolar_mean_px)},
          {"epipolar_systematic_px", FigureOrNull(s.epipolar_systematic_px)},
          {"epipolar_systematic_sigma_px", FigureOrNull(s.epipolar_systematic_sigma_px)},
          {"epipolar_samples", s.epipolar_samples},
          {"epipolar_source", s.epipolar_source},
          {"projector_bias_px", FigureOrNull(s.projector_bias_px)},
          {"projector_rms_px", FigureOrNull(s.projector_rms_px)},
          {"projector_systematic_px", FigureOrNull(s.projector_systematic_px)},
          {"projector_samples", s.projector_samples}};
}

void MeasureProjectorConsistency(const StereoRig& rig, const OrganizedPointCloud& cloud,
                                 const cv::Mat& phase_left, const DriftOptions& options,
                                 ViewDrift* drift) {
  if (!rig.projector || phase_left.empty() || phase_left.type() != CV_32F ||
      phase_left.cols != cloud.width || phase_left.rows != cloud.height) {
    return;
  }
  const size_t valid = cloud.NumValid();
  const size_t stride = std::max<size_t>(
      1, (valid + options.max_samples - 1) / static_cast<size_t>(options.max_samples));
  struct Sample {
    double u, v, e;  // left pixel normalised by the focal length; residual, projector px
  };
  std::vector<Sample> samples;
  samples.reserve(std::min<size_t>(valid, static_cast<size_t>(options.max_samples)));
  size_t k = 0;
  for (int r = 0; r < cloud.height; ++r) {
    for (int c = 0; c < cloud.width; ++c) {
      const size_t i = cloud.index(c, r);
      if (!cloud.valid[i] || (k++ % stride) != 0) continue;
      const float phi = phase_left.at<float>(r, c);
      if (!std::isfinite(phi)) continue;
      const Eigen::Vector3d p = rig.projector_from_left * cloud.cloud.points[i];
      if (!(p.z() > 0)) continue;
      const double e = rig.projector->Project(p).x() - phi;
      if (!std::isfinite(e)) continue;
      samples.push_back({(c - rig.left.cx) / rig.left.fx, (r - rig.left.cy) / rig.left.fy, e});
    }
  }
  const size_t n = samples.size();
  drift->projector_samples = static_cast<int>(n);
  if (n == 0) return;
  double sum = 0, sum2 = 0;
  for (const Sample& s : samples) {
    sum += s.e;
    sum2 += s.e * s.e;
  }
  drift->projector_bias_px = sum / static_cast<double>(n);
  drift->projector_rms_px = std::sqrt(sum2 / static_cast<double>(n));

  // The systematic part: a + b u + c v fitted by least squares to the residuals within 5 robust
  // sigmas of their median (a mismatch at an edge is off by a fringe, far more than any tilt),
  // RMS of the plane's values at those points.
  std::vector<double> e(n);
  for (size_t j = 0; j < n; ++j) e[j] = samples[j].e;
  const auto median = [](std::vector<double>* v) {
    std::nth_element(v->begin(), v->begin() + static_cast<std::ptrdiff_t>(v->size() / 2), v->end());
    return (*v)[v->size() / 2];
  };
  const double med = median(&e);
  for (size_t j = 0; j < n; ++j) e[j] = std::abs(samples[j].e - med);
  const double max_dev = 5 * 1.4826 * median(&e);
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  double used = 0;
  for (const Sample& s : samples) {
    if (std::abs(s.e - med) > max_dev) continue;
    const Eigen::Vector3d a(1, s.u, s.v);
    normal += a * a.transpose();
    rhs += s.e * a;
    ++used;
  }
  if (used < 3) return;
  const Eigen::Vector3d plane = normal.ldlt().solve(rhs);
  // Sum over the points of (a . plane)^2 = plane' normal plane.
  drift->projector_systematic_px = std::sqrt(std::max(0.0, plane.dot(normal * plane)) / used);
}

void MeasureMarkerEpipolar(const StereoRig& rig,
                           const std::vector<registration::ViewMarker>& markers, ViewDrift* drift) {
  std::vector<double> d;
  std::vector<Eigen::Vector2d> at;  // left position, normalised by the focal length
  for (const registration::ViewMarker& m : markers) {
    if (!m.left_px.allFinite() || !m.right_px.allFinite()) continue;
    const double e = SignedEpipolarDistancePx(rig, m.left_px, m.right_px);
    if (!std::isfinite(e)) continue;
    d.push_back(e);
    at.emplace_back((m.left_px.x() - rig.left.cx) / rig.left.fx,
                    (m.left_px.y() - rig.left.cy) / rig.left.fy);
  }
  const int n = static_cast<int>(d.size());
  drift->epipolar_samples = n;
  drift->epipolar_source = "markers";
  if (n == 0) return;
  double sum = 0, sum2 = 0;
  for (double e : d) {
    sum += e;
    sum2 += e * e;
  }
  drift->epipolar_mean_px = sum / n;
  drift->epipolar_rms_px = std::sqrt(sum2 / n);
  // The systematic part: a small rotation or shift of a camera moves the epipolar residual by
  // a + b x + c y over the image to first order (pitch and a vertical shift: a; roll: b x), while
  // the centres' noise averages out of the fit. Least squares of that plane (its mean alone with
  // fewer than 6 markers), RMS of its values at the markers.
  Eigen::MatrixXd A(n, n >= 6 ? 3 : 1);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    A(i, 0) = 1;
    if (A.cols() == 3) {
      A(i, 1) = at[static_cast<size_t>(i)].x();
      A(i, 2) = at[static_cast<size_t>(i)].y();
    }
    b(i) = d[static_cast<size_t>(i)];
  }
  const Eigen::VectorXd fit = A * Eigen::VectorXd(A.colPivHouseholderQr().solve(b));
  drift->epipolar_systematic_px = std::sqrt(fit.squaredNorm() / n);
  // Its standard error: with centre noise sigma the plane's p parameters carry p sigma^2 of the
  // sum of squares, so RMS ~ sigma sqrt(p / n); sigma from the scatter about the plane.
  const Eigen::Index p = A.cols();
  if (n > p) {
    const double sigma = std::sqrt((b - fit).squaredNorm() / static_cast<double>(n - p));
    drift->epipolar_systematic_sigma_px = sigma * std::sqrt(static_cast<double>(p) / n);
  }
}

void MeasureTwoDirectionResidual(const OrganizedPointCloud& cloud, ViewDrift* drift) {
  const PointCloud& c = cloud.cloud;
  if (!c.has_residual()) return;
  double sum2 = 0;
  int n = 0;
  for (size_t i = 0; i < cloud.valid.size() && i < c.residual_px.size(); ++i) {
    const double e = c.residual_px[i];
    if (!cloud.valid[i] || !std::isfinite(e)) continue;
    sum2 += e * e;
    ++n;
  }
  drift->epipolar_samples = n;
  drift->epipolar_source = "two-direction phase";
  if (n > 0) drift->epipolar_rms_px = std::sqrt(sum2 / n);
}

void DecideDrift(const DriftOptions& options, ViewDrift* d) {
  d->checked = d->drift = false;
  d->evidence.clear();
  std::vector<std::string> exceeded;
  if (d->epipolar_source == "markers" && d->epipolar_samples >= options.min_markers &&
      std::isfinite(d->epipolar_rms_px)) {
    d->checked = true;
    d->evidence.push_back(StrCat("markers (", d->epipolar_samples, " in both images)"));
    // Too few markers for a scatter (sigma NaN): the size threshold alone.
    const double sigma = d->epipolar_systematic_sigma_px;
    const bool significant = !(std::isfinite(sigma)) ||
                             d->epipolar_systematic_px > options.min_epipolar_significance * sigma;
    if (d->epipolar_systematic_px > options.max_epipolar_systematic_px && significant) {
      exceeded.push_back(
          StrCat("the markers' systematic epipolar residual ", Fixed(d->epipolar_systematic_px, 3),
                 " px (RMS ", Fixed(d->epipolar_rms_px, 3), " px, mean ",
                 Fixed(d->epipolar_mean_px, 3), " px, standard error ", Fixed(sigma, 3),
                 " px) exceeds ", options.max_epipolar_systematic_px, " px and ",
                 options.min_epipolar_significance, " standard errors"));
    }
  }
  if (d->epipolar_source == "two-direction phase" &&
      d->epipolar_samples >= options.min_projector_points && std::isfinite(d->epipolar_rms_px)) {
    d->checked = true;
    d->evidence.push_back(StrCat("two-direction phase (", d->epipolar_samples, " points)"));
    if (d->epipolar_rms_px > options.max_two_direction_rms_px) {
      exceeded.push_back(StrCat("the two-direction residual RMS ", Fixed(d->epipolar_rms_px, 3),
                                " px exceeds ", options.max_two_direction_rms_px, " px"));
    }
  }
  if (d->projector_samples >= options.min_projector_points && std::isfinite(d->projector_bias_px)) {
    d->checked = true;
    d->evidence.push_back(StrCat("calibrated projector (", d->projector_samples, " points)"));
    if (std::abs(d->projector_bias_px) > options.max_projector_bias_px) {
      exceeded.push_back(StrCat("the points' mean projector column residual ",
                                Fixed(d->projector_bias_px, 3), " px exceeds +-",
                                options.max_projector_bias_px, " px"));
    } else if (d->projector_systematic_px > options.max_projector_systematic_px) {
      exceeded.push_back(
          StrCat("the points' projector column residual varies across the image "
                 "(RMS of the fitted plane ",
                 Fixed(d->projector_systematic_px, 4), " px, mean ", Fixed(d->projector_bias_px, 4),
                 " px) by more than ", options.max_projector_systematic_px,
                 " px: a roll or a shift along the optical axis"));
    }
  }
  d->drift = !exceeded.empty();
  if (d->drift) {
    d->message = "calibration drift: ";
    for (size_t i = 0; i < exceeded.size(); ++i) d->message += (i ? "; " : "") + exceeded[i];
  } else if (d->checked) {
    d->message = "consistent with the calibration";
  } else {
    d->message = StrCat(
        "not checked: no redundant evidence (", d->epipolar_samples, " ",
        d->epipolar_source.empty() ? "epipolar samples" : d->epipolar_source, ", ",
        d->projector_samples,
        " points against a calibrated projector; with one camera and one fringe direction the "
        "projector column is what triangulates a point: nothing is left to compare)");
  }
}

double PooledEpipolarRmsPx(const std::vector<const ViewDrift*>& views) {
  double sum2 = 0;
  int64_t n = 0;
  for (const ViewDrift* v : views) {
    if (v->epipolar_samples <= 0 || !std::isfinite(v->epipolar_rms_px)) continue;
    sum2 += v->epipolar_rms_px * v->epipolar_rms_px * v->epipolar_samples;
    n += v->epipolar_samples;
  }
  return n ? std::sqrt(sum2 / static_cast<double>(n)) : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace fringe::pipeline
