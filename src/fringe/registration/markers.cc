#include "fringe/registration/markers.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "fringe/io/calibration_io.h"
#include "fringe/io/json.h"
#include "fringe/stereo/triangulation.h"
#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::registration {

using Eigen::Vector2d;
using Eigen::Vector3d;
using nlohmann::json;
using util::StrCat;

void MarkerDetectionOptions::Check() const {
  rings.Check();
  const char* o = "MarkerDetectionOptions";
  util::CheckOption(inner_to_outer_ratio > 0 && inner_to_outer_ratio < 1, o, "inner_to_outer_ratio",
                    inner_to_outer_ratio, "must be in (0, 1)");
  util::CheckOption(max_epipolar_px > 0, o, "max_epipolar_px", max_epipolar_px, "must be > 0");
  util::CheckOption(max_depth_difference_mm > 0, o, "max_depth_difference_mm",
                    max_depth_difference_mm, "must be > 0");
  util::CheckOption(relative_depth_difference >= 0, o, "relative_depth_difference",
                    relative_depth_difference, "must be >= 0");
  util::CheckOption(min_outer_radius_mm > 0, o, "min_outer_radius_mm", min_outer_radius_mm,
                    "must be > 0");
  util::CheckOption(max_outer_radius_mm > min_outer_radius_mm, o, "max_outer_radius_mm",
                    max_outer_radius_mm, "must be > min_outer_radius_mm");
  util::CheckOption(surface_radius_factor > 1, o, "surface_radius_factor", surface_radius_factor,
                    "must be > 1");
  util::CheckOption(min_surface_points >= 3, o, "min_surface_points", min_surface_points,
                    "must be >= 3");
}

const char* ToString(MarkerDetectionStatus s) {
  switch (s) {
    case MarkerDetectionStatus::kOk:
      return "ok";
    case MarkerDetectionStatus::kNoMarkers:
      return "no markers";
  }
  return "?";
}

std::string MarkerDetectionSummary::BriefReport() const {
  std::string s = StrCat("markers: ", ToString(status), ", ", markers, " markers from ", rings_left,
                         " left / ", rings_right, " right rings (", ambiguous_resolved,
                         " resolved by depth), ", rejected.size(), " rejected");
  if (!message.empty()) s += ": " + message;
  return s;
}

double EpipolarDistancePx(const StereoRig& rig, const Vector2d& left_px, const Vector2d& right_px) {
  return std::abs(SignedEpipolarDistancePx(rig, left_px, right_px));
}

namespace {

cv::Mat To8Bit(const cv::Mat& texture, const char* side) {
  if (texture.empty() || texture.channels() != 1) {
    throw Error(StrCat("DetectViewMarkers: the ", side, " texture is empty or not single-channel"));
  }
  if (texture.depth() == CV_8U) return texture;
  if (texture.depth() != CV_32F) {
    throw Error(StrCat("DetectViewMarkers: the ", side, " texture must be CV_8U or CV_32F"));
  }
  cv::Mat f = texture.clone();
  cv::patchNaNs(f, 0);
  cv::Mat out;
  f.convertTo(out, CV_8U);
  return out;
}

// The surface around a marker: a plane fitted to the cloud's valid points within radius_px of
// the left image centre, with one pass dropping points off the plane (the ring's own dark, noisy
// points, a neighbouring step).
struct SurfacePlane {
  bool ok = false;
  Vector3d point = Vector3d::Zero();
  Vector3d normal = Vector3d::UnitZ();  // toward the sensor
  int points = 0;
};

SurfacePlane FitSurface(const OrganizedPointCloud& cloud, const Vector2d& centre_px,
                        double radius_px, int min_points) {
  SurfacePlane plane;
  std::vector<Vector3d> pts;
  const int c0 = static_cast<int>(std::floor(centre_px.x() - radius_px));
  const int c1 = static_cast<int>(std::ceil(centre_px.x() + radius_px));
  const int r0 = static_cast<int>(std::floor(centre_px.y() - radius_px));
  const int r1 = static_cast<int>(std::ceil(centre_px.y() + radius_px));
  for (int r = std::max(0, r0); r <= std::min(cloud.height - 1, r1); ++r) {
    for (int c = std::max(0, c0); c <= std::min(cloud.width - 1, c1); ++c) {
      if ((Vector2d(c, r) - centre_px).norm() > radius_px) continue;
      const size_t i = cloud.index(c, r);
      if (!cloud.valid[i] || !cloud.cloud.points[i].allFinite()) continue;
      pts.push_back(cloud.cloud.points[i]);
    }
  }
  for (int pass = 0; pass < 2; ++pass) {
    if (static_cast<int>(pts.size()) < min_points) return plane;
    Vector3d mean = Vector3d::Zero();
    for (const auto& p : pts) mean += p;
    mean /= static_cast<double>(pts.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& p : pts) cov += (p - mean) * (p - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    Vector3d n = eig.eigenvectors().col(0);
    if (n.dot(mean) > 0) n = -n;
    plane.point = mean;
    plane.normal = n;
    plane.points = static_cast<int>(pts.size());
    if (pass == 1) break;
    double ss = 0;
    for (const auto& p : pts) ss += std::pow(n.dot(p - mean), 2);
    const double keep = std::max(0.05, 3 * std::sqrt(ss / pts.size()));
    std::vector<Vector3d> kept;
    for (const auto& p : pts) {
      if (std::abs(n.dot(p - mean)) <= keep) kept.push_back(p);
    }
    pts.swap(kept);
  }
  plane.ok = plane.points >= min_points;
  return plane;
}

// Variance of one coordinate of an ellipse's fitted centre, px^2: a circle's centre fitted to N
// independent points with orthogonal residual sigma is known to sigma * sqrt(2 / N). Edge
// samples are ~1 px apart while the pre-smoothing and the Sobel kernel spread each pixel's noise
// over ~4 of them, so N / 4 samples count as independent; sigma is the ellipse's own RMS
// residual (at least 0.02 px).
double EllipseCentreVariance(const std::vector<Vector2d>& edge_px, const calib::Ellipse& e) {
  if (edge_px.empty()) return 0;
  double ss = 0;
  for (const Vector2d& p : edge_px) ss += std::pow(e.SignedDistance(p), 2);
  const double rms = std::max(std::sqrt(ss / static_cast<double>(edge_px.size())), 0.02);
  const double n = static_cast<double>(edge_px.size()) / 4;
  return rms * rms * 2.0 / std::max(n, 1.0);
}

// Centre uncertainty of a fitted ring in pixels (1 sigma per image coordinate). The ring centre
// is the pole-polar centre of its two ellipses (calib::RingCentre), to first order their centres
// extrapolated to radius 0: c = (c_inner - q c_outer) / (1 - q), q = (inner/outer radius)^2. The
// inner ellipse's noise is therefore amplified by 1 / (1 - q) (1.56 for the 0.6 markers) and the
// outer one's by q / (1 - q). Treating the centre as one circle fitted to all edge points of both
// ellipses (the model before) predicted 2.2x too small a scatter on the simulated demo scan
// (bench_registration's marker_sigma_ratio; docs/benchmarks.md).
double CentreSigmaPx(const calib::FeatureObservation& f, double inner_to_outer_ratio) {
  const double var_outer = EllipseCentreVariance(f.outer_edge_px, f.outer);
  if (f.inner_edge_px.empty()) return std::sqrt(var_outer);  // no inner ellipse: its centre
  const double var_inner = EllipseCentreVariance(f.inner_edge_px, f.inner);
  const double q = inner_to_outer_ratio * inner_to_outer_ratio;
  return std::sqrt(var_inner + q * q * var_outer) / (1 - q);
}

// Stable order (by left image row, then column; ids follow it), counts, status and time.
void FinishViewMarkers(const char* image, const util::Timer& timer, ViewMarkers* out) {
  MarkerDetectionSummary& s = out->summary;
  std::sort(out->markers.begin(), out->markers.end(), [](const ViewMarker& a, const ViewMarker& b) {
    return a.left_px.y() != b.left_px.y() ? a.left_px.y() < b.left_px.y()
                                          : a.left_px.x() < b.left_px.x();
  });
  for (size_t k = 0; k < out->markers.size(); ++k) out->markers[k].id = static_cast<int>(k);
  s.markers = static_cast<int>(out->markers.size());
  s.status = s.markers > 0 ? MarkerDetectionStatus::kOk : MarkerDetectionStatus::kNoMarkers;
  if (s.markers == 0) {
    s.message = StrCat("no marker found (", s.rings_left, " rings in the ", image, ")");
  }
  s.seconds = timer.ElapsedSeconds();
}

struct Choice {
  int right = -1;
  Vector3d p = Vector3d::Zero();
  double diff_mm = 0;
  int candidates = 0;
};

}  // namespace

ViewMarkers DetectViewMarkers(const StereoRig& rig, const cv::Mat& texture_left,
                              const cv::Mat& texture_right, const OrganizedPointCloud& cloud,
                              const MarkerDetectionOptions& options) {
  options.Check();
  util::Timer timer;
  const cv::Mat left8 = To8Bit(texture_left, "left"), right8 = To8Bit(texture_right, "right");
  if (left8.cols != rig.left.width || left8.rows != rig.left.height ||
      right8.cols != rig.right.width || right8.rows != rig.right.height) {
    throw Error("DetectViewMarkers: texture sizes differ from the rig's cameras");
  }
  if (cloud.width != rig.left.width || cloud.height != rig.left.height) {
    throw Error("DetectViewMarkers: the cloud is not on the left camera's grid");
  }
  const calib::RingDetection rl =
      calib::DetectRings(left8, options.inner_to_outer_ratio, options.rings);
  const calib::RingDetection rr =
      calib::DetectRings(right8, options.inner_to_outer_ratio, options.rings);
  ViewMarkers out;
  MarkerDetectionSummary& s = out.summary;
  s.rings_left = static_cast<int>(rl.rings.size());
  s.rings_right = static_cast<int>(rr.rings.size());
  for (const auto& r : rl.rejected) s.rejected.push_back({r.centre_px, "left image: " + r.reason});

  std::vector<Choice> choice(rl.rings.size());
  std::vector<SurfacePlane> planes(rl.rings.size());
  for (size_t i = 0; i < rl.rings.size(); ++i) {
    const calib::FeatureObservation& L = rl.rings[i];
    const SurfacePlane plane = FitSurface(
        cloud, L.centre_px, options.surface_radius_factor * L.outer.a, options.min_surface_points);
    planes[i] = plane;
    if (!plane.ok) {
      s.rejected.push_back(
          {L.centre_px, StrCat("no measured surface around the ring (", plane.points, " points)")});
      continue;
    }
    const Vector3d ray = rig.left.Ray(L.centre_px);
    const double den = plane.normal.dot(ray);
    if (std::abs(den) < 1e-3) {
      s.rejected.push_back({L.centre_px, "surface seen edge-on"});
      continue;
    }
    const double surface_range = plane.normal.dot(plane.point) / den;
    double best = std::numeric_limits<double>::infinity();
    for (size_t j = 0; j < rr.rings.size(); ++j) {
      const calib::FeatureObservation& R = rr.rings[j];
      if (EpipolarDistancePx(rig, L.centre_px, R.centre_px) > options.max_epipolar_px) continue;
      const stereo::TriangulatedPoint tp = stereo::Triangulate(rig, L.centre_px, R.centre_px);
      if (!tp.ok()) continue;
      ++choice[i].candidates;
      const double diff = tp.p_in_left.dot(ray) - surface_range;
      if (std::abs(diff) < best) {
        best = std::abs(diff);
        choice[i].right = static_cast<int>(j);
        choice[i].p = tp.p_in_left;
        choice[i].diff_mm = diff;
      }
    }
    if (choice[i].right < 0) {
      s.rejected.push_back({L.centre_px, "no ring of the right image on its epipolar line"});
      continue;
    }
    const double tol =
        options.max_depth_difference_mm + options.relative_depth_difference * choice[i].p.z();
    if (best > tol) {
      s.rejected.push_back({L.centre_px, StrCat("no epipolar candidate lies on the measured "
                                                "surface (best depth difference ",
                                                choice[i].diff_mm, " mm)")});
      choice[i].right = -1;
      continue;
    }
    const double radius_mm = L.outer.a * choice[i].p.norm() / rig.left.fx;
    if (radius_mm < options.min_outer_radius_mm || radius_mm > options.max_outer_radius_mm) {
      s.rejected.push_back({L.centre_px, StrCat("ring of outer radius ", radius_mm,
                                                " mm, outside the accepted marker sizes")});
      choice[i].right = -1;
    }
  }
  // One right ring for one left ring: the better depth agreement keeps it.
  std::map<int, size_t> owner;
  for (size_t i = 0; i < choice.size(); ++i) {
    if (choice[i].right < 0) continue;
    auto it = owner.find(choice[i].right);
    if (it == owner.end()) {
      owner[choice[i].right] = i;
    } else if (std::abs(choice[i].diff_mm) < std::abs(choice[it->second].diff_mm)) {
      s.rejected.push_back({rl.rings[it->second].centre_px,
                            "its right ring matches another "
                            "marker better"});
      it->second = i;
    } else {
      s.rejected.push_back({rl.rings[i].centre_px, "its right ring matches another marker better"});
    }
  }
  for (const auto& [right, i] : owner) {
    const calib::FeatureObservation& L = rl.rings[i];
    const calib::FeatureObservation& R = rr.rings[right];
    ViewMarker m;
    m.left_px = L.centre_px;
    m.right_px = R.centre_px;
    m.centre_in_sensor = choice[i].p;
    m.normal_in_sensor = planes[i].normal;
    m.depth_difference_mm = choice[i].diff_mm;
    m.outer_radius_mm = L.outer.a * m.centre_in_sensor.norm() / rig.left.fx;
    // Covariance of the centre from the image centres' uncertainty (numeric Jacobian of the
    // triangulation, one image coordinate at a time).
    const double sl = CentreSigmaPx(L, options.inner_to_outer_ratio),
                 sr = CentreSigmaPx(R, options.inner_to_outer_ratio);
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (int k = 0; k < 4; ++k) {
      Vector2d lp = m.left_px, rp = m.right_px;
      const double sigma = k < 2 ? sl : sr;
      (k < 2 ? lp : rp)[k % 2] += sigma;
      const stereo::TriangulatedPoint tp = stereo::Triangulate(rig, lp, rp);
      if (!tp.ok()) continue;
      const Vector3d d = tp.p_in_left - m.centre_in_sensor;
      cov += d * d.transpose();
    }
    m.sigma_mm = std::sqrt(cov.trace());
    m.covariance_mm2 = cov;
    if (choice[i].candidates > 1) ++s.ambiguous_resolved;
    out.markers.push_back(m);
  }
  FinishViewMarkers("left image", timer, &out);
  return out;
}

ViewMarkers DetectViewMarkersOneCamera(const CameraModel& camera, const cv::Mat& texture,
                                       const OrganizedPointCloud& cloud,
                                       const MarkerDetectionOptions& options) {
  options.Check();
  util::Timer timer;
  const cv::Mat image8 = To8Bit(texture, "camera");
  if (image8.cols != camera.width || image8.rows != camera.height) {
    throw Error("DetectViewMarkersOneCamera: the texture size differs from the camera's");
  }
  if (cloud.width != camera.width || cloud.height != camera.height) {
    throw Error("DetectViewMarkersOneCamera: the cloud is not on the camera's grid");
  }
  const calib::RingDetection rings =
      calib::DetectRings(image8, options.inner_to_outer_ratio, options.rings);
  ViewMarkers out;
  MarkerDetectionSummary& s = out.summary;
  s.rings_left = static_cast<int>(rings.rings.size());
  for (const auto& r : rings.rejected) {
    s.rejected.push_back({r.centre_px, "camera image: " + r.reason});
  }
  // Where the ray through `px` meets the plane (NaN when it does not, in front of the camera).
  auto intersect = [&](const Vector2d& px, const SurfacePlane& plane) {
    const Vector3d ray = camera.Ray(px);
    const double den = plane.normal.dot(ray);
    const double t = plane.normal.dot(plane.point) / den;
    return t > 0 ? Vector3d(t * ray) : Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  };
  for (const calib::FeatureObservation& ring : rings.rings) {
    const SurfacePlane plane =
        FitSurface(cloud, ring.centre_px, options.surface_radius_factor * ring.outer.a,
                   options.min_surface_points);
    if (!plane.ok) {
      s.rejected.push_back({ring.centre_px, StrCat("no measured surface around the ring (",
                                                   plane.points, " points)")});
      continue;
    }
    if (std::abs(plane.normal.dot(camera.Ray(ring.centre_px))) < 1e-3) {
      s.rejected.push_back({ring.centre_px, "surface seen edge-on"});
      continue;
    }
    ViewMarker m;
    m.left_px = ring.centre_px;
    m.right_px = Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    m.centre_in_sensor = intersect(ring.centre_px, plane);
    if (!m.centre_in_sensor.allFinite()) {
      s.rejected.push_back({ring.centre_px, "the surface is behind the camera"});
      continue;
    }
    m.normal_in_sensor = plane.normal;
    m.outer_radius_mm = ring.outer.a * m.centre_in_sensor.norm() / camera.fx;
    if (m.outer_radius_mm < options.min_outer_radius_mm ||
        m.outer_radius_mm > options.max_outer_radius_mm) {
      s.rejected.push_back({ring.centre_px, StrCat("ring of outer radius ", m.outer_radius_mm,
                                                   " mm, outside the accepted marker sizes")});
      continue;
    }
    // Uncertainty: the image centre moved by its sigma in each coordinate (numeric Jacobian of
    // the ray-plane intersection), plus the plane's standard error along its normal (the RMS of
    // the fitted points about it over the square root of their number).
    const double sigma_px = CentreSigmaPx(ring, options.inner_to_outer_ratio);
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (int k = 0; k < 2; ++k) {
      Vector2d px = m.left_px;
      px[k] += sigma_px;
      const Vector3d p = intersect(px, plane);
      if (!p.allFinite()) continue;
      const Vector3d d = p - m.centre_in_sensor;
      cov += d * d.transpose();
    }
    double ss = 0;
    int n = 0;
    const double radius_px = options.surface_radius_factor * ring.outer.a;
    for (int r = std::max(0, static_cast<int>(ring.centre_px.y() - radius_px));
         r <= std::min(cloud.height - 1, static_cast<int>(ring.centre_px.y() + radius_px)); ++r) {
      for (int c = std::max(0, static_cast<int>(ring.centre_px.x() - radius_px));
           c <= std::min(cloud.width - 1, static_cast<int>(ring.centre_px.x() + radius_px)); ++c) {
        const size_t i = cloud.index(c, r);
        if (!cloud.valid[i] || (Vector2d(c, r) - ring.centre_px).norm() > radius_px) continue;
        const double d = plane.normal.dot(cloud.cloud.points[i] - plane.point);
        // The plane fit dropped points beyond 3 RMS (FitSurface); so does the error estimate.
        if (std::abs(d) > 1.0) continue;
        ss += d * d;
        ++n;
      }
    }
    const double plane_sigma_mm = n > 3 ? std::sqrt(ss / (n - 3)) / std::sqrt(n) : 0;
    m.sigma_mm = std::sqrt(cov.trace() + plane_sigma_mm * plane_sigma_mm);
    // The plane's error moves the centre along the ray, by plane_sigma / cos(incidence).
    const Vector3d ray = m.centre_in_sensor.normalized();
    const double along = plane_sigma_mm / std::max(0.1, std::abs(plane.normal.dot(ray)));
    m.covariance_mm2 = cov + along * along * ray * ray.transpose();
    m.depth_difference_mm = 0;
    out.markers.push_back(m);
  }
  FinishViewMarkers("camera image", timer, &out);
  return out;
}

Eigen::Matrix3d CentreCovariance(const ViewMarker& m, double min_sigma_mm) {
  const double floor2 = min_sigma_mm * min_sigma_mm;
  if (m.covariance_mm2.isZero(0) || !m.covariance_mm2.allFinite()) {
    return Eigen::Matrix3d::Identity() * std::max(m.sigma_mm * m.sigma_mm, floor2) / 3;
  }
  // Every direction at least floor2 / 3, so that the inverse exists (a Jacobian from a
  // degenerate triangulation can leave a direction at zero).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(m.covariance_mm2);
  const Eigen::Vector3d l = eig.eigenvalues().cwiseMax(floor2 / 3);
  return eig.eigenvectors() * l.asDiagonal() * eig.eigenvectors().transpose();
}

// ---- Files ----

namespace {

// A marker file of a real scan holds a few hundred markers; more is refused before reading.
constexpr size_t kMaxMarkersInFile = 100000;

json Vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }
json Vec(const Eigen::Vector2d& v) { return json::array({v.x(), v.y()}); }
Eigen::Vector3d Vec3(const json& j, const char* key, const std::string& context) {
  const std::vector<double> v = io::GetNumbers(j, key, 3, context);
  return {v[0], v[1], v[2]};
}

}  // namespace

std::filesystem::path MarkersPathForCloud(const std::filesystem::path& cloud_path) {
  std::filesystem::path p = cloud_path;
  p.replace_extension(".markers.json");
  return p;
}

void WriteViewMarkers(const std::filesystem::path& path, const std::vector<ViewMarker>& markers) {
  json list = json::array();
  for (const ViewMarker& m : markers) {
    list.push_back({{"id", m.id},
                    {"centre_in_sensor", Vec(m.centre_in_sensor)},
                    {"normal_in_sensor", Vec(m.normal_in_sensor)},
                    {"left_px", Vec(m.left_px)},
                    {"right_px", m.right_px.allFinite() ? Vec(m.right_px) : json(nullptr)},
                    {"outer_radius_mm", m.outer_radius_mm},
                    {"sigma_mm", m.sigma_mm},
                    {"depth_difference_mm", m.depth_difference_mm}});
    if (!m.covariance_mm2.isZero(0)) {
      const Eigen::Matrix3d& c = m.covariance_mm2;
      list.back()["covariance_mm2"] = {c(0, 0), c(0, 1), c(0, 2), c(1, 1), c(1, 2), c(2, 2)};
    }
  }
  io::WriteJson(path, {{"format", "fringe-view-markers"},
                       {"version", 1},
                       {"frame", "sensor (left camera), mm"},
                       {"markers", list}});
}

std::vector<ViewMarker> ReadViewMarkers(const std::filesystem::path& path) {
  return ViewMarkersFromJson(io::ReadJson(path), path.string());  // bounded in size and depth
}

std::vector<ViewMarker> ViewMarkersFromJson(const json& j, const std::string& ctx) {
  io::RequireObject(j, ctx);
  if (io::OptionalString(j, "format", "fringe-view-markers", ctx) != "fringe-view-markers") {
    throw Error(ctx + ".format: expected \"fringe-view-markers\"");
  }
  io::OptionalInteger(j, "version", 1, 1, 1, ctx);
  io::CheckKnownKeys(j, {"format", "version", "frame", "markers"}, ctx);
  io::OptionalString(j, "frame", "", ctx);  // descriptive, but a string
  if (!j.contains("markers") || !j["markers"].is_array()) {
    throw Error(ctx + ".markers: expected an array");
  }
  const json& list = j["markers"];
  if (list.size() > kMaxMarkersInFile) {
    throw Error(StrCat(ctx, ".markers: ", list.size(), " entries, more than the ",
                       kMaxMarkersInFile, " accepted"));
  }
  std::vector<ViewMarker> out;
  out.reserve(list.size());
  for (size_t k = 0; k < list.size(); ++k) {
    const json& e = list[k];
    const std::string c = StrCat(ctx, ".markers[", k, "]");
    ViewMarker m;
    m.id = static_cast<int>(io::GetInteger(e, "id", 0, std::numeric_limits<int>::max(), c));
    m.centre_in_sensor = Vec3(e, "centre_in_sensor", c);
    m.normal_in_sensor = Vec3(e, "normal_in_sensor", c);
    if (std::abs(m.normal_in_sensor.norm() - 1) > 1e-3) {
      throw Error(
          StrCat(c, ".normal_in_sensor: not a unit vector (norm ", m.normal_in_sensor.norm(), ")"));
    }
    m.normal_in_sensor.normalize();
    const std::vector<double> l = io::GetNumbers(e, "left_px", 2, c);
    m.left_px = Eigen::Vector2d(l[0], l[1]);
    // null: a one-camera view (DetectViewMarkersOneCamera) has no right image.
    if (e.contains("right_px") && e["right_px"].is_null()) {
      m.right_px = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    } else {
      const std::vector<double> r = io::GetNumbers(e, "right_px", 2, c);
      m.right_px = Eigen::Vector2d(r[0], r[1]);
    }
    m.outer_radius_mm = io::GetNumber(e, "outer_radius_mm", c);
    m.sigma_mm = io::GetNumber(e, "sigma_mm", c);
    m.depth_difference_mm = io::OptionalNumber(e, "depth_difference_mm", 0, c);
    if (m.sigma_mm < 0) throw Error(c + ".sigma_mm: must be >= 0");
    if (e.contains("covariance_mm2")) {
      const std::vector<double> v = io::GetNumbers(e, "covariance_mm2", 6, c);
      // Bounded before any arithmetic: a centre uncertain by a metre is no marker, and larger
      // entries would overflow the eigen-decomposition below.
      for (double x : v) {
        if (std::abs(x) > 1e6) throw Error(c + ".covariance_mm2: entry beyond 1e6 mm^2");
      }
      m.covariance_mm2 << v[0], v[1], v[2], v[1], v[3], v[4], v[2], v[4], v[5];
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(m.covariance_mm2);
      // Rounding in the written digits may leave a tiny negative eigenvalue; more is no
      // covariance.
      if (eig.eigenvalues().minCoeff() < -1e-9 * std::max(1e-30, eig.eigenvalues().maxCoeff())) {
        throw Error(c + ".covariance_mm2: not positive semi-definite");
      }
    }
    if (m.outer_radius_mm <= 0) throw Error(c + ".outer_radius_mm: must be > 0");
    if (m.centre_in_sensor.z() <= 0) throw Error(c + ".centre_in_sensor: behind the sensor");
    out.push_back(m);
  }
  return out;
}

}  // namespace fringe::registration
