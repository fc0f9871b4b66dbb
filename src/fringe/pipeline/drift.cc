#include "fringe/pipeline/drift.h"

#include <Eigen/Dense>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "fringe/util/error.h"

namespace fringe::pipeline {
namespace {

using util::StrCat;

std::string Fixed(double v, int digits) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(digits) << v;
  return os.str();
}

nlohmann::json Figure(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

}  // namespace

void DriftOptions::Check() const {
  using util::CheckOption;
  const char* o = "DriftOptions";
  CheckOption(max_epipolar_systematic_px > 0, o, "max_epipolar_systematic_px",
              max_epipolar_systematic_px, "must be > 0");
  CheckOption(min_markers >= 2, o, "min_markers", min_markers, "must be >= 2");
  CheckOption(max_projector_bias_px > 0, o, "max_projector_bias_px", max_projector_bias_px,
              "must be > 0");
  CheckOption(min_projector_points >= 1, o, "min_projector_points", min_projector_points,
              "must be >= 1");
  CheckOption(max_two_direction_rms_px > 0, o, "max_two_direction_rms_px", max_two_direction_rms_px,
              "must be > 0");
  CheckOption(max_samples >= 100, o, "max_samples", max_samples, "must be >= 100");
}

nlohmann::json ViewDrift::ToJson() const {
  return {{"checked", checked},
          {"drift", drift},
          {"evidence", evidence},
          {"message", message},
          {"epipolar_rms_px", Figure(epipolar_rms_px)},
          {"epipolar_mean_px", Figure(epipolar_mean_px)},
          {"epipolar_systematic_px", Figure(epipolar_systematic_px)},
          {"epipolar_samples", epipolar_samples},
          {"epipolar_source", epipolar_source},
          {"projector_bias_px", Figure(projector_bias_px)},
          {"projector_rms_px", Figure(projector_rms_px)},
          {"projector_samples", projector_samples}};
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
  double sum = 0, sum2 = 0;
  int n = 0;
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
      sum += e;
      sum2 += e * e;
      ++n;
    }
  }
  drift->projector_samples = n;
  if (n == 0) return;
  drift->projector_bias_px = sum / n;
  drift->projector_rms_px = std::sqrt(sum2 / n);
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
    if (d->epipolar_systematic_px > options.max_epipolar_systematic_px) {
      exceeded.push_back(StrCat(
          "the markers' systematic epipolar residual ", Fixed(d->epipolar_systematic_px, 3),
          " px (RMS ", Fixed(d->epipolar_rms_px, 3), " px, mean ", Fixed(d->epipolar_mean_px, 3),
          " px) exceeds ", options.max_epipolar_systematic_px, " px"));
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
