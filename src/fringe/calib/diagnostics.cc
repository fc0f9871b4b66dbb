#include "fringe/calib/diagnostics.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "fringe/calib/calibrate_folder.h"
#include "fringe/calib/calibration_scene.h"
#include "fringe/io/json.h"
#include "fringe/util/error.h"
#include "fringe/util/format.h"

namespace fringe::calib {
namespace {

using util::CheckOption;
using util::Fixed;
using util::StrCat;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Midpoint of the closest points of the two pixel rays (left frame). The stereo module's
// triangulation sits in a later layer; the prediction needs only the geometry of two rays.
bool TriangulateMidpoint(const StereoRig& rig, const Eigen::Vector2d& left_px,
                         const Eigen::Vector2d& right_px, Eigen::Vector3d* point_in_left) {
  const Eigen::Vector3d dl = rig.left.Unproject(left_px).homogeneous();
  const Eigen::Matrix3d r_t = rig.right_from_left.rotation_matrix().transpose();
  const Eigen::Vector3d c = -r_t * rig.right_from_left.translation();
  const Eigen::Vector3d dr = r_t * rig.right.Unproject(right_px).homogeneous();
  // Minimise |s dl - (c + t dr)|: the 2 x 2 normal equations.
  const double a = dl.dot(dl), b = dl.dot(dr), cc = dr.dot(dr);
  const double d = dl.dot(c), e = dr.dot(c);
  const double det = a * cc - b * b;
  if (!(std::abs(det) > 1e-12 * a * cc)) return false;  // parallel rays
  const double s = (d * cc - b * e) / det;
  const double t = (b * d - a * e) / det;
  *point_in_left = 0.5 * (s * dl + c + t * dr);
  return point_in_left->allFinite();
}

constexpr int kRigParameters = 2 * kNumIntrinsics + kPoseBlockSize;

Eigen::VectorXd RigParameters(const StereoRig& rig) {
  Eigen::VectorXd theta(kRigParameters);
  const IntrinsicsBlock l = IntrinsicsBlockOf(rig.left), r = IntrinsicsBlockOf(rig.right);
  const PoseBlock p = PoseBlockOf(rig.right_from_left);
  for (int k = 0; k < kNumIntrinsics; ++k) {
    theta[k] = l[size_t(k)];
    theta[kNumIntrinsics + k] = r[size_t(k)];
  }
  for (int k = 0; k < kPoseBlockSize; ++k) theta[2 * kNumIntrinsics + k] = p[size_t(k)];
  return theta;
}

StereoRig RigWithParameters(const StereoRig& nominal, const Eigen::VectorXd& theta) {
  StereoRig rig = nominal;
  SetIntrinsicsFromBlock(theta.data(), &rig.left);
  SetIntrinsicsFromBlock(theta.data() + kNumIntrinsics, &rig.right);
  rig.right_from_left = RigidFromPoseBlock(theta.data() + 2 * kNumIntrinsics);
  return rig;
}

bool InsideImage(const CameraModel& cam, const Eigen::Vector2d& px) {
  return px.x() >= -0.5 && px.y() >= -0.5 && px.x() <= cam.width - 0.5 &&
         px.y() <= cam.height - 0.5;
}

// Cells of the coverage grid for an image: `cells` along the longer side.
cv::Size CoverageGrid(int width, int height, int cells) {
  const double cell_px = double(std::max(width, height)) / cells;
  return {std::max(1, int(std::ceil(width / cell_px))),
          std::max(1, int(std::ceil(height / cell_px)))};
}

cv::Mat Enlarge(const cv::Mat& m, int width_px) {
  cv::Mat out;
  const double f = double(width_px) / m.cols;
  cv::resize(m, out, cv::Size(width_px, std::max(1, int(std::lround(m.rows * f)))), 0, 0,
             cv::INTER_NEAREST);
  return out;
}

}  // namespace

void DiagnosticsOptions::Check() const {
  const char* o = "DiagnosticsOptions";
  CheckOption(min_distance_mm > 0 && min_distance_mm < max_distance_mm, o, "min_distance_mm",
              min_distance_mm, "must be > 0 and < max_distance_mm");
  CheckOption(min_fov_deg > 0 && min_fov_deg < max_fov_deg && max_fov_deg < 180, o, "min_fov_deg",
              min_fov_deg, "must be > 0 and < max_fov_deg < 180");
  CheckOption(pixel_size_um >= 0 && std::isfinite(pixel_size_um), o, "pixel_size_um", pixel_size_um,
              "must be >= 0 (0: unknown)");
  CheckOption(min_focal_mm > 0 && min_focal_mm < max_focal_mm, o, "min_focal_mm", min_focal_mm,
              "must be > 0 and < max_focal_mm");
  CheckOption(max_aspect_deviation > 0, o, "max_aspect_deviation", max_aspect_deviation,
              "must be > 0");
  CheckOption(min_coverage >= 0 && min_coverage <= 1, o, "min_coverage", min_coverage,
              "must be in [0, 1]");
  CheckOption(coverage_cells >= 8 && coverage_cells <= 512, o, "coverage_cells", coverage_cells,
              "must be in [8, 512]");
  CheckOption(min_poses >= 1, o, "min_poses", min_poses, "must be >= 1");
  CheckOption(min_tilt_deg >= 0 && min_tilt_deg < 90, o, "min_tilt_deg", min_tilt_deg,
              "must be in [0, 90)");
  CheckOption(prediction_cells >= 4 && prediction_cells <= 256, o, "prediction_cells",
              prediction_cells, "must be in [4, 256]");
}

double PredictedDepthSigmaMm(const StereoRig& rig, const Eigen::MatrixXd& cov,
                             const Eigen::Vector3d& point_in_left) {
  if (cov.rows() != kRigParameters || cov.cols() != kRigParameters) return kNaN;
  const Eigen::Vector3d in_right = rig.right_from_left * point_in_left;
  if (!(point_in_left.z() > 0) || !(in_right.z() > 0)) return kNaN;
  // The pixel pair the nominal rig sees; a perturbed rig triangulates the same pixels.
  const Eigen::Vector2d ul = rig.left.Project(point_in_left);
  const Eigen::Vector2d ur = rig.right.Project(in_right);
  const Eigen::VectorXd theta = RigParameters(rig);
  Eigen::RowVectorXd jacobian = Eigen::RowVectorXd::Zero(kRigParameters);
  for (int k = 0; k < kRigParameters; ++k) {
    const double var = cov(k, k);
    if (!(var > 0)) continue;  // held fixed
    // Central differences over half a standard deviation: the depth is smooth in the
    // parameters, and the step stays in the range the covariance describes.
    const double h = 0.5 * std::sqrt(var);
    Eigen::VectorXd plus = theta, minus = theta;
    plus[k] += h;
    minus[k] -= h;
    Eigen::Vector3d p_plus, p_minus;
    if (!TriangulateMidpoint(RigWithParameters(rig, plus), ul, ur, &p_plus) ||
        !TriangulateMidpoint(RigWithParameters(rig, minus), ul, ur, &p_minus)) {
      return kNaN;
    }
    jacobian[k] = (p_plus.z() - p_minus.z()) / (2 * h);
  }
  const double var_z = jacobian * cov * jacobian.transpose();
  return std::sqrt(std::max(0.0, var_z));
}

bool CalibrationDiagnostics::has_warning(const std::string& code) const {
  return std::find(warning_codes.begin(), warning_codes.end(), code) != warning_codes.end();
}

std::string CalibrationDiagnostics::BriefReport() const {
  std::ostringstream os;
  os << "calibration diagnostics: " << used_poses << " poses used, " << rejections.size()
     << " rejected";
  for (const DeviceDiagnostics& d : devices) {
    os << "; " << d.name << " RMS " << Fixed(d.rms_px, 3) << " px, max " << Fixed(d.max_px, 3)
       << " px, coverage " << Fixed(100 * d.coverage, 0) << " %";
  }
  if (!predicted_depth_sigma_mm.empty()) {
    os << "; predicted depth sigma " << Fixed(predicted_depth_sigma_mm.front().sigma_mm * 1000, 1)
       << " um at the volume's centre";
  }
  os << "; " << warnings.size() << " warning" << (warnings.size() == 1 ? "" : "s");
  for (const std::string& w : warnings) os << "\n  warning: " << w;
  for (const std::string& r : rejections) os << "\n  rejected: " << r;
  return os.str();
}

CalibrationDiagnostics DiagnoseCalibration(
    const std::vector<DiagnosedDevice>& devices, const std::vector<std::string>& pose_names,
    const CalibrationTarget& target,
    const std::vector<std::pair<std::string, double>>& distances_mm, const StereoCalibration* pair,
    const DiagnosticsOptions& options) {
  options.Check();
  if (devices.empty()) throw Error("calibration diagnostics: no device");
  for (const DiagnosedDevice& d : devices) {
    if (!d.calibration) throw Error("calibration diagnostics: device " + d.name + " has no result");
  }
  CalibrationDiagnostics out;
  out.distances_mm = distances_mm;
  auto warn = [&](const char* code, const std::string& text) {
    out.warning_codes.push_back(code);
    out.warnings.push_back(text);
  };
  const CameraCalibration& reference = *devices[0].calibration;
  const size_t num_views = reference.summary.views.size();

  // Poses.
  for (size_t v = 0; v < num_views; ++v) {
    PoseDiagnostics p;
    p.name = v < pose_names.size() ? pose_names[v] : StrCat("pose ", v);
    p.used = reference.summary.views[v].used;
    for (const DiagnosedDevice& d : devices) {
      const auto& views = d.calibration->summary.views;
      const bool has = v < views.size();
      p.rms_px.push_back(has ? views[v].rms_px : 0);
      p.max_px.push_back(has ? views[v].max_px : 0);
      p.features.push_back(has ? views[v].num_features : 0);
      if (has && p.message.empty() && !views[v].used) p.message = views[v].message;
    }
    if (p.used && v < reference.camera_from_board.size()) {
      const Eigen::Vector3d normal = reference.camera_from_board[v].rotation_matrix().col(2);
      p.tilt_deg = std::acos(std::min(1.0, std::abs(normal.z()))) * 180 / M_PI;
      out.max_tilt_deg = std::max(out.max_tilt_deg, p.tilt_deg);
      ++out.used_poses;
    }
    if (!p.used && p.message.rfind("rejected", 0) == 0) {
      out.rejections.push_back(StrCat("pose ", p.name, ": ", p.message));
    }
    out.poses.push_back(std::move(p));
  }

  // Devices: residuals, coverage, focal length.
  for (const DiagnosedDevice& d : devices) {
    const CameraCalibration& cal = *d.calibration;
    DeviceDiagnostics dd;
    dd.name = d.name;
    dd.width = cal.camera.width;
    dd.height = cal.camera.height;
    double ss = 0;
    int n = 0;
    for (const ViewResidual& v : cal.summary.views) {
      if (!v.used || v.num_features == 0) continue;
      ss += v.rms_px * v.rms_px * v.num_features;
      n += v.num_features;
      dd.max_px = std::max(dd.max_px, v.max_px);
    }
    dd.rms_px = n ? std::sqrt(ss / n) : 0;
    const cv::Size grid = CoverageGrid(dd.width, dd.height, options.coverage_cells);
    const double cell_px = double(std::max(dd.width, dd.height)) / options.coverage_cells;
    dd.coverage_map = cv::Mat::zeros(grid, CV_32F);
    for (size_t v = 0; v < cal.centres_px.size(); ++v) {
      const bool used = v < cal.summary.views.size() && cal.summary.views[v].used;
      if (!used || cal.centres_px[v].size() < 3) continue;
      // The board's hull in cell units (the centre of cell (c, r) is at ((c + 0.5) cell_px - 0.5)).
      std::vector<cv::Point> pts, hull;
      for (const Eigen::Vector2d& px : cal.centres_px[v]) {
        pts.emplace_back(cvRound((px.x() + 0.5) / cell_px * 16),
                         cvRound((px.y() + 0.5) / cell_px * 16));
      }
      cv::convexHull(pts, hull);
      cv::Mat mask = cv::Mat::zeros(grid, CV_8U);
      // Sub-cell precision (shift 4): a cell counts when its centre is inside the hull.
      for (cv::Point& h : hull) h -= cv::Point(8, 8);
      cv::fillConvexPoly(mask, hull, cv::Scalar(1), cv::LINE_8, 4);
      cv::Mat add;
      mask.convertTo(add, CV_32F);
      dd.coverage_map += add;
    }
    dd.coverage = double(cv::countNonZero(dd.coverage_map)) / dd.coverage_map.total();
    dd.fx = cal.camera.fx;
    dd.fy = cal.camera.fy;
    dd.fov_deg = 2 * std::atan(0.5 * dd.width / dd.fx) * 180 / M_PI;
    if (options.pixel_size_um > 0) dd.focal_mm = dd.fx * options.pixel_size_um / 1000;
    out.devices.push_back(dd);
  }

  // Plausibility.
  for (const auto& [name, mm] : distances_mm) {
    if (mm < options.min_distance_mm || mm > options.max_distance_mm) {
      warn("distance",
           StrCat(name, " ", Fixed(mm, 4), " mm is outside ", options.min_distance_mm, " mm - ",
                  options.max_distance_mm / 1000, " m: ",
                  mm < options.min_distance_mm
                      ? "were the board's or the translations' units metres, not millimetres?"
                      : "were the board's or the translations' units micrometres, not "
                        "millimetres?"));
    }
  }
  for (const DeviceDiagnostics& d : out.devices) {
    if (d.fov_deg < options.min_fov_deg || d.fov_deg > options.max_fov_deg) {
      warn("focal",
           StrCat(d.name, ": focal length ", Fixed(d.fx, 1), " px gives a field of view of ",
                  Fixed(d.fov_deg, 2), " deg for ", d.width, " px, outside the plausible ",
                  options.min_fov_deg, " - ", options.max_fov_deg, " deg"));
    }
    if (options.pixel_size_um > 0 &&
        (d.focal_mm < options.min_focal_mm || d.focal_mm > options.max_focal_mm)) {
      warn("focal",
           StrCat(d.name, ": focal length ", Fixed(d.fx, 1), " px x ", options.pixel_size_um,
                  " um pixels = ", Fixed(d.focal_mm, 2), " mm, outside the plausible ",
                  options.min_focal_mm, " - ", options.max_focal_mm, " mm for that pixel size"));
    }
    if (std::abs(d.fx / d.fy - 1) > options.max_aspect_deviation) {
      warn("aspect", StrCat(d.name, ": fx / fy = ", Fixed(d.fx / d.fy, 4),
                            ": non-square pixels are rare; the focal length is poorly "
                            "constrained (more tilted poses)"));
    }
    if (d.coverage < options.min_coverage) {
      warn("coverage", StrCat(d.name, ": the board covered ", Fixed(100 * d.coverage, 0),
                              " % of the sensor (< ", Fixed(100 * options.min_coverage, 0),
                              " %): the distortion is unconstrained where nothing fell; add poses "
                              "near the uncovered edges and corners"));
    }
  }
  if (out.used_poses < options.min_poses) {
    warn("few_poses", StrCat("only ", out.used_poses, " poses used (< ", options.min_poses,
                             "): the focal length and distortion are poorly determined"));
  }
  if (out.used_poses > 0 && out.max_tilt_deg < options.min_tilt_deg) {
    warn("no_tilt", StrCat("no pose is tilted by more than ", Fixed(out.max_tilt_deg, 1),
                           " deg against the camera (< ", options.min_tilt_deg,
                           " deg): with fronto-parallel boards the focal length and the distance "
                           "are not separable; tilt the board by 20 - 45 deg in some poses"));
  }

  // Predicted depth uncertainty over the working volume.
  if (!pair) {
    out.prediction_message = "no second device: no triangulation to predict";
  } else if (pair->rig_covariance.rows() != kRigParameters) {
    out.prediction_message = "the calibration's covariance is not available";
  } else {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    for (size_t v = 0; v < num_views && v < reference.camera_from_board.size(); ++v) {
      if (!reference.summary.views[v].used) continue;
      for (int r = 0; r < target.rows; ++r) {
        for (int c = 0; c < target.cols; ++c) {
          const Eigen::Vector3d p = reference.camera_from_board[v] * target.FeatureCentre(r, c);
          lo = lo.cwiseMin(p);
          hi = hi.cwiseMax(p);
        }
      }
    }
    if (!(hi.array() >= lo.array()).all()) {
      out.prediction_message = "no used pose to span a working volume";
    } else {
      const StereoRig& rig = pair->rig;
      const Eigen::MatrixXd& cov = pair->rig_covariance;
      const Eigen::Vector3d centre = 0.5 * (lo + hi);
      out.predicted_depth_sigma_mm.push_back(
          {"centre", centre, PredictedDepthSigmaMm(rig, cov, centre)});
      for (int k = 0; k < 8; ++k) {
        const Eigen::Vector3d p((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(),
                                (k & 4) ? hi.z() : lo.z());
        out.predicted_depth_sigma_mm.push_back(
            {StrCat("corner ", k + 1), p, PredictedDepthSigmaMm(rig, cov, p)});
      }
      const cv::Size grid = CoverageGrid(rig.left.width, rig.left.height, options.prediction_cells);
      const double cell_px =
          double(std::max(rig.left.width, rig.left.height)) / options.prediction_cells;
      out.predicted_sigma_map = cv::Mat(grid, CV_32F, cv::Scalar(kNaN));
      for (int r = 0; r < grid.height; ++r) {
        for (int c = 0; c < grid.width; ++c) {
          const Eigen::Vector2d px((c + 0.5) * cell_px - 0.5, (r + 0.5) * cell_px - 0.5);
          const Eigen::Vector3d p = centre.z() * rig.left.Unproject(px).homogeneous();
          const Eigen::Vector3d in_right = rig.right_from_left * p;
          if (!(in_right.z() > 0) || !InsideImage(rig.right, rig.right.Project(in_right))) {
            continue;
          }
          out.predicted_sigma_map.at<float>(r, c) =
              static_cast<float>(PredictedDepthSigmaMm(rig, cov, p));
        }
      }
    }
  }
  return out;
}

nlohmann::json ToJson(const CalibrationDiagnostics& d) {
  nlohmann::json poses = nlohmann::json::array();
  for (const PoseDiagnostics& p : d.poses) {
    nlohmann::json devices = nlohmann::json::object();
    for (size_t k = 0; k < d.devices.size(); ++k) {
      devices[d.devices[k].name] = {
          {"rms_px", p.rms_px[k]}, {"max_px", p.max_px[k]}, {"features", p.features[k]}};
    }
    nlohmann::json jp = {{"name", p.name}, {"used", p.used}, {"devices", devices}};
    if (p.used) jp["tilt_deg"] = p.tilt_deg;
    if (!p.message.empty()) jp["message"] = p.message;
    poses.push_back(jp);
  }
  nlohmann::json devices = nlohmann::json::array();
  for (const DeviceDiagnostics& v : d.devices) {
    nlohmann::json jd = {{"name", v.name},         {"rms_px", v.rms_px}, {"max_px", v.max_px},
                         {"coverage", v.coverage}, {"fx", v.fx},         {"fy", v.fy},
                         {"fov_deg", v.fov_deg}};
    if (v.focal_mm > 0) jd["focal_mm"] = v.focal_mm;
    devices.push_back(jd);
  }
  nlohmann::json warnings = nlohmann::json::array();
  for (size_t k = 0; k < d.warnings.size(); ++k) {
    warnings.push_back({{"code", d.warning_codes[k]}, {"message", d.warnings[k]}});
  }
  nlohmann::json distances = nlohmann::json::object();
  for (const auto& [name, mm] : d.distances_mm) distances[name] = mm;
  nlohmann::json j = {{"used_poses", d.used_poses},
                      {"max_tilt_deg", d.max_tilt_deg},
                      {"devices", devices},
                      {"distances_mm", distances},
                      {"poses", poses},
                      {"rejections", d.rejections},
                      {"warnings", warnings}};
  if (d.predicted_depth_sigma_mm.empty()) {
    j["predicted_depth_sigma_mm"] = nullptr;
    j["prediction_message"] = d.prediction_message;
  } else {
    nlohmann::json sigma = nlohmann::json::array();
    for (const DepthSigma& s : d.predicted_depth_sigma_mm) {
      const Eigen::Vector3d& p = s.point_in_left;
      nlohmann::json js = {{"where", s.where}, {"point_in_left_mm", {p.x(), p.y(), p.z()}}};
      js["sigma_mm"] = std::isfinite(s.sigma_mm) ? nlohmann::json(s.sigma_mm) : nlohmann::json();
      sigma.push_back(js);
    }
    j["predicted_depth_sigma_mm"] = sigma;
  }
  return j;
}

io::Report CalibrationReport(const CalibrationDiagnostics& d,
                             const std::vector<DiagnosedDevice>& devices) {
  io::Report r;
  r.title = "Calibration report";
  {
    io::ReportSection s;
    s.title = "Summary";
    s.paragraphs.push_back(StrCat(d.used_poses, " board poses used, ", d.rejections.size(),
                                  " rejected as outliers among the poses; ", d.warnings.size(),
                                  d.warnings.size() == 1 ? " warning." : " warnings."));
    for (const std::string& w : d.warnings) s.paragraphs.push_back("Warning: " + w);
    for (const std::string& w : d.rejections) s.paragraphs.push_back("Rejected " + w);
    io::ReportTable t;
    t.caption = "Devices";
    t.header = {"device", "RMS, px", "max, px",           "coverage",
                "fx, px", "fy, px",  "field of view, deg"};
    for (const DeviceDiagnostics& v : d.devices) {
      t.rows.push_back({v.name, Fixed(v.rms_px, 3), Fixed(v.max_px, 3),
                        Fixed(100 * v.coverage, 0) + " %", Fixed(v.fx, 1), Fixed(v.fy, 1),
                        Fixed(v.fov_deg, 2)});
    }
    s.tables.push_back(t);
    if (!d.distances_mm.empty()) {
      io::ReportTable dt;
      dt.caption = "Distances from the first camera";
      dt.header = {"device", "distance, mm"};
      for (const auto& [name, mm] : d.distances_mm) dt.rows.push_back({name, Fixed(mm, 3)});
      s.tables.push_back(dt);
    }
    r.sections.push_back(s);
  }
  {
    io::ReportSection s;
    s.title = "Board poses";
    io::ReportTable t;
    t.header = {"pose", "used", "tilt, deg"};
    for (const DeviceDiagnostics& v : d.devices) {
      t.header.push_back(v.name + " RMS, px");
      t.header.push_back(v.name + " max, px");
    }
    t.header.push_back("note");
    for (const PoseDiagnostics& p : d.poses) {
      std::vector<std::string> row = {p.name, p.used ? "yes" : "no",
                                      p.used ? Fixed(p.tilt_deg, 1) : "-"};
      for (size_t k = 0; k < d.devices.size(); ++k) {
        row.push_back(p.features[k] ? Fixed(p.rms_px[k], 3) : "-");
        row.push_back(p.features[k] ? Fixed(p.max_px[k], 3) : "-");
      }
      row.push_back(p.message);
      t.rows.push_back(row);
    }
    s.tables.push_back(t);
    r.sections.push_back(s);
  }
  for (size_t k = 0; k < d.devices.size() && k < devices.size(); ++k) {
    io::ReportSection s;
    s.title = "Device: " + d.devices[k].name;
    cv::Mat residuals = ResidualImage(*devices[k].calibration);
    if (residuals.cols > 640) {
      cv::resize(residuals, residuals,
                 cv::Size(640, std::max(1, residuals.rows * 640 / residuals.cols)), 0, 0,
                 cv::INTER_AREA);
    }
    s.images.push_back(
        {"Residual vectors (magnified) at every feature of the used poses; the "
         "boards' hulls shaded",
         residuals});
    cv::Mat coverage = d.devices[k].coverage_map.clone();
    double peak = 1;
    cv::minMaxLoc(coverage, nullptr, &peak);
    coverage.setTo(kNaN, coverage == 0);
    s.images.push_back(
        {StrCat("Coverage: poses whose board covered each cell (grey: none), ",
                Fixed(100 * d.devices[k].coverage, 0), " % of the sensor"),
         io::ColourMapWithBar(Enlarge(coverage, 640), 0, std::max(1.0, peak), "poses", 640)});
    r.sections.push_back(s);
  }
  {
    io::ReportSection s;
    s.title = "Predicted depth uncertainty";
    if (d.predicted_depth_sigma_mm.empty()) {
      s.paragraphs.push_back(d.prediction_message);
    } else {
      s.paragraphs.push_back(
          "The calibration's share of the depth uncertainty: the joint covariance of the rig "
          "parameters propagated through the triangulation of a fixed pixel pair, over the "
          "working volume spanned by the calibration's board poses (left camera frame).");
      io::ReportTable t;
      t.header = {"where", "x, mm", "y, mm", "z, mm", "depth sigma, um"};
      for (const DepthSigma& p : d.predicted_depth_sigma_mm) {
        t.rows.push_back({p.where, Fixed(p.point_in_left.x(), 1), Fixed(p.point_in_left.y(), 1),
                          Fixed(p.point_in_left.z(), 1),
                          std::isfinite(p.sigma_mm) ? Fixed(1000 * p.sigma_mm, 2) : "-"});
      }
      s.tables.push_back(t);
      if (!d.predicted_sigma_map.empty()) {
        cv::Mat um = d.predicted_sigma_map * 1000;
        const auto range = io::DisplayRange(um, 0.0);
        s.images.push_back(
            {StrCat("Predicted depth sigma over the left image at the volume "
                    "centre's depth z = ",
                    Fixed(d.predicted_depth_sigma_mm.front().point_in_left.z(), 1),
                    " mm (grey: outside the other device's image)"),
             io::ColourMapWithBar(Enlarge(um, 640), range[0], range[1], "depth sigma, um", 640)});
      }
    }
    r.sections.push_back(s);
  }
  return r;
}

CalibrationDiagnosis DiagnoseFolderCalibration(const FolderCalibration& cal,
                                               const CalibrationTarget& target,
                                               const DiagnosticsOptions& options) {
  CalibrationDiagnosis out;
  out.target = target;
  if (cal.stereo) {
    out.devices = {{"left", &cal.pair.left}, {"right", &cal.pair.right}};
    out.diagnostics =
        DiagnoseCalibration(out.devices, cal.names, target,
                            {{"baseline", cal.pair.rig.BaselineMm()}}, &cal.pair, options);
  } else {
    out.devices = {{"camera", &cal.mono}};
    out.diagnostics = DiagnoseCalibration(out.devices, cal.names, target, {}, nullptr, options);
  }
  return out;
}

CalibrationDiagnosis DiagnoseProjectorCalibration(const ProjectorFolderCalibration& cal,
                                                  const CalibrationTarget& target,
                                                  const DiagnosticsOptions& options) {
  CalibrationDiagnosis out;
  out.target = target;
  if (cal.layout == ProjectorFolderLayout::kCamerasProjector) {
    const MultiDeviceCalibration& j = cal.cameras.joint;
    const char* names[] = {"left", "right", "projector"};
    std::vector<std::pair<std::string, double>> distances;
    for (size_t d = 0; d < j.devices.size() && d < 3; ++d) {
      out.devices.push_back({names[d], &j.devices[d]});
      if (d > 0 && d < j.device_from_reference.size()) {
        distances.emplace_back(d == 1 ? "baseline" : "projector distance",
                               j.device_from_reference[d].translation().norm());
      }
    }
    out.diagnostics =
        DiagnoseCalibration(out.devices, cal.names, target, distances, nullptr, options);
    out.diagnostics.prediction_message =
        "two cameras + projector: the depth prediction is given for stereo and camera + "
        "projector calibrations";
  } else {
    const StereoCalibration& j = cal.camera_projector.joint;
    out.devices = {{"camera", &j.left}, {"projector", &j.right}};
    out.diagnostics = DiagnoseCalibration(
        out.devices, cal.names, target, {{"projector distance", j.rig.BaselineMm()}}, &j, options);
  }
  return out;
}

void WriteCalibrationReport(const std::filesystem::path& dir, const CalibrationDiagnosis& d,
                            const nlohmann::json& calibration_json,
                            const util::OutputFolderOptions& output) {
  const nlohmann::json summary = {{"calibration", calibration_json},
                                  {"diagnostics", ToJson(d.diagnostics)}};
  io::Report report = CalibrationReport(d.diagnostics, d.devices);
  io::ReportSection view;
  view.title = "Board poses and devices in 3D";
  view.paragraphs.push_back(
      "The board at every used pose, coloured by the pose's RMS reprojection residual, and the "
      "devices at their calibrated poses. A click on a pose's or a device's row in the tables "
      "shows it here.");
  view.scene = CalibrationScene(d.diagnostics, d.devices, d.target);
  report.sections.insert(report.sections.begin() + std::min<size_t>(1, report.sections.size()),
                         std::move(view));
  util::WriteFolderAtomically(dir, output, [&](const std::filesystem::path& tmp) {
    io::WriteJson(tmp / "summary.json", summary);
    report.Write(tmp / "report.html");
  });
}

}  // namespace fringe::calib
