#include "fringe/calib/calibrate.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <optional>
#include <sstream>

#include "fringe/calib/ellipse.h"
#include "fringe/util/error.h"

namespace fringe::calib {

void CalibrationOptions::Check() const {
  using util::CheckOption;
  const char* o = "CalibrationOptions";
  CheckOption(max_iterations >= 1, o, "max_iterations", max_iterations, "must be >= 1");
  CheckOption(centre_rounds >= 0 && centre_rounds <= 10, o, "centre_rounds", centre_rounds,
              "must be in [0, 10]");
  CheckOption(max_image_rms_px > 0, o, "max_image_rms_px", max_image_rms_px, "must be > 0");
  CheckOption(outlier_sigma > 0, o, "outlier_sigma", outlier_sigma, "must be > 0");
  CheckOption(min_features >= 4, o, "min_features", min_features, "must be >= 4");
  CheckOption(min_views >= 2, o, "min_views", min_views, "must be >= 2");
  CheckOption(loss_scale_px > 0, o, "loss_scale_px", loss_scale_px, "must be > 0");
}

const char* ToString(CalibrationStatus s) {
  switch (s) {
    case CalibrationStatus::kSuccess:
      return "success";
    case CalibrationStatus::kTooFewViews:
      return "too_few_views";
    case CalibrationStatus::kInitialisationFailed:
      return "initialisation_failed";
    case CalibrationStatus::kNotConverged:
      return "not_converged";
    case CalibrationStatus::kNotFinite:
      return "not_finite";
    case CalibrationStatus::kCameraFailed:
      return "camera_failed";
  }
  return "unknown";
}

std::string CalibrationSummary::BriefReport() const {
  std::ostringstream os;
  os << (ok() ? "success" : util::StrCat("FAILED (", ToString(status), ")")) << ": RMS "
     << initial_rms_px << " -> " << final_rms_px << " px, " << num_views_used << " views used, "
     << num_views_rejected << " rejected, " << num_features << " features, " << iterations
     << " iterations, " << ceres::TerminationTypeToString(solve.termination);
  if (!message.empty()) os << " (" << message << ")";
  return os.str();
}

std::string StereoCalibration::BriefReport() const {
  std::ostringstream os;
  os << summary.BriefReport() << "; baseline " << rig.BaselineMm() << " mm, " << num_pairs
     << " pairs, epipolar RMS " << epipolar_rms_px << " px, max " << epipolar_max_px << " px";
  return os.str();
}

namespace {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// One feature observation in the bundle.
struct Obs {
  int device = 0;  // 0: reference (left) camera; others through device_from_reference
  int view = 0;    // board pose index
  Vec3 board_point;
  Vec2 px;  // measured centre
  const FeatureObservation* feature = nullptr;
  bool active = true;
};

// Intrinsics of N devices (cameras, projector), one reference_from_board pose per view and a
// device_from_reference pose per device after the first, refined by Ceres (bundle.h).
class Bundle {
 public:
  std::vector<CameraModel> devices;
  std::vector<PoseBlock> reference_from_board;   // per view
  std::vector<PoseBlock> device_from_reference;  // per device; [0] is the identity, not solved
  std::vector<bool> view_used;
  std::vector<Obs> obs;
  FreeIntrinsics free_intrinsics{};
  RobustLoss loss = RobustLoss::kNone;
  double loss_scale_px = 1;
  SolveOptions solve_options;

  // Standard deviations of the last solve, per device (zero where not estimated).
  std::vector<IntrinsicsBlock> std_intrinsics;
  std::vector<PoseBlock> std_device_from_reference;
  bool std_dev_ok = false;
  // With want_covariance, the joint covariance of the last solve's intrinsics blocks (devices
  // in order) and device_from_reference blocks (devices 1.. in order); empty when unknown.
  bool want_covariance = false;
  Eigen::MatrixXd covariance;

  Rigid3d DeviceFromBoard(int device, int view) const {
    const Rigid3d reference_from_board_pose = RigidFromPoseBlock(reference_from_board[view].data());
    if (device == 0) return reference_from_board_pose;
    return RigidFromPoseBlock(device_from_reference[device].data()) * reference_from_board_pose;
  }

  Vec2 Project(const Obs& o) const {
    const Vec3 p = DeviceFromBoard(o.device, o.view) * o.board_point;
    if (p.z() <= 1e-6) return Vec2(1e6, 1e6);
    return devices[o.device].Project(p);
  }

  bool Counts(const Obs& o) const { return o.active && view_used[o.view]; }

  double Rms() const {
    double ss = 0;
    int n = 0;
    for (const Obs& o : obs) {
      if (!Counts(o)) continue;
      ss += (Project(o) - o.px).squaredNorm();
      ++n;
    }
    return n ? std::sqrt(ss / n) : 0;
  }

  // One Ceres solve over the active observations; updates the parameters and the standard
  // deviations in place.
  SolveReport Solve() {
    std::vector<IntrinsicsBlock> intrinsics(devices.size());
    for (size_t d = 0; d < devices.size(); ++d) intrinsics[d] = IntrinsicsBlockOf(devices[d]);
    ceres::Problem problem;
    // One loss object for all blocks; the problem owns it (and deletes it once).
    ceres::LossFunction* loss_function = NewLossFunction(loss, loss_scale_px);
    std::vector<bool> device_seen(devices.size(), false);
    for (const Obs& o : obs) {
      if (!Counts(o)) continue;
      double* pose = reference_from_board[o.view].data();
      if (o.device == 0) {
        problem.AddResidualBlock(BoardReprojectionCost::Create(o.board_point, o.px), loss_function,
                                 intrinsics[0].data(), pose);
      } else {
        problem.AddResidualBlock(ChainedReprojectionCost::Create(o.board_point, o.px),
                                 loss_function, intrinsics[o.device].data(),
                                 device_from_reference[o.device].data(), pose);
      }
      device_seen[o.device] = true;
    }
    if (problem.NumResidualBlocks() == 0) {
      delete loss_function;
      SolveReport r;
      r.message = "no observations";
      return r;
    }
    for (size_t d = 0; d < devices.size(); ++d) {
      if (!device_seen[d]) continue;
      if (ceres::Manifold* m = NewIntrinsicsManifold(free_intrinsics)) {
        problem.SetManifold(intrinsics[d].data(), m);
      }
    }
    const SolveReport report = calib::Solve(solve_options, &problem);
    for (size_t d = 0; d < devices.size(); ++d) {
      SetIntrinsicsFromBlock(intrinsics[d].data(), &devices[d]);
    }
    // Standard deviations at this optimum.
    std::vector<const double*> blocks;
    for (size_t d = 0; d < devices.size(); ++d) {
      if (device_seen[d]) blocks.push_back(intrinsics[d].data());
    }
    for (size_t d = 1; d < devices.size(); ++d) {
      if (device_seen[d]) blocks.push_back(device_from_reference[d].data());
    }
    std::vector<std::vector<double>> std_devs;
    std_dev_ok =
        StandardDeviations(&problem, blocks, &std_devs, want_covariance ? &covariance : nullptr);
    std_intrinsics.assign(devices.size(), IntrinsicsBlock{});
    std_device_from_reference.assign(devices.size(), PoseBlock{});
    size_t i = 0;
    for (size_t d = 0; d < devices.size(); ++d) {
      if (!device_seen[d]) continue;
      if (std_dev_ok) std::copy_n(std_devs[i].begin(), kNumIntrinsics, std_intrinsics[d].begin());
      ++i;
    }
    for (size_t d = 1; d < devices.size(); ++d) {
      if (!device_seen[d]) continue;
      if (std_dev_ok) {
        std::copy_n(std_devs[i].begin(), kPoseBlockSize, std_device_from_reference[d].begin());
      }
      ++i;
    }
    return report;
  }

  int NumActive() const {
    int n = 0;
    for (const Obs& o : obs) n += Counts(o) ? 1 : 0;
    return n;
  }
};

// Re-measures a circular feature's centre with the current camera and pose (header comment).
// Returns false when the edge points do not give a centre (the previous one is kept).
bool RemeasureCentre(const FeatureObservation& f, const CalibrationTarget& target,
                     const CameraModel& cam, const Rigid3d& cam_from_board, Vec2* centre_px) {
  if (f.outer_edge_px.size() < 5) return false;
  // Ideal (undistorted) pinhole pixels: K * normalized.
  auto ideal = [&](const std::vector<Vec2>& pts) {
    std::vector<Vec2> out;
    out.reserve(pts.size());
    for (const auto& p : pts) out.push_back(cam.PixelFromNormalized(cam.Unproject(p)));
    return out;
  };
  EllipseFitOptions fo;
  fo.outlier_rounds = 1;
  const auto outer = FitEllipse(ideal(f.outer_edge_px), fo);
  if (!outer) return false;
  // Perspective bias of an ellipse centre predicted from the pose: centre of the projected
  // circle's conic minus the projection of the circle's centre (ideal pixels).
  const Eigen::Matrix3d r = cam_from_board.rotation_matrix();
  Eigen::Matrix3d h;
  h.col(0) = r.col(0);
  h.col(1) = r.col(1);
  h.col(2) = cam_from_board.translation();
  h = cam.K() * h;
  const Vec3 centre_board = target.FeatureCentre(f.row, f.col);
  const Vec2 projected = (h * Vec3(centre_board.x(), centre_board.y(), 1)).hnormalized();
  auto corrected = [&](const EllipseFitResult& fit, double radius_mm) -> std::optional<Vec2> {
    const auto cc = ConicCentre(ProjectCircle(h, centre_board.head<2>(), radius_mm));
    if (!cc) return std::nullopt;
    return Vec2(fit.ellipse.centre - (*cc - projected));
  };
  Vec2 c_ideal;
  const auto c_outer = corrected(*outer, target.outer_radius_mm);
  if (!c_outer) return false;
  if (target.type == TargetType::kConcentricRings) {
    if (f.inner_edge_px.size() < 5) return false;
    const auto inner = FitEllipse(ideal(f.inner_edge_px), fo);
    if (!inner) return false;
    // The pose-free pole-polar centre must agree (it guards against a wrong pose or edges);
    // with the pose known, the bias-corrected ellipse centres of both edges are less noisy
    // than the pencil construction, so they are combined with inverse-variance weights
    // (centre variance ~ rms^2 / n).
    const auto c_pp =
        RingCentre(outer->ellipse, inner->ellipse, target.inner_radius_mm / target.outer_radius_mm);
    const auto c_inner = corrected(*inner, target.inner_radius_mm);
    if (!c_pp || !c_inner) return false;
    const double wo = outer->num_points / std::max(1e-6, std::pow(outer->rms_residual, 2));
    const double wi = inner->num_points / std::max(1e-6, std::pow(inner->rms_residual, 2));
    c_ideal = (wo * *c_outer + wi * *c_inner) / (wo + wi);
    if ((c_ideal - *c_pp).norm() >
        0.1 + 0.5 * (outer->ellipse.centre - inner->ellipse.centre).norm()) {
      return false;
    }
  } else {
    c_ideal = *c_outer;
  }
  *centre_px = cam.PixelFromNormalized(cam.Distort(cam.NormalizedDistortedFromPixel(c_ideal)));
  return centre_px->allFinite();
}

bool IsCircular(const CalibrationTarget& t) { return t.type != TargetType::kChessboard; }

// Initial camera, distortion and poses.
bool Initialise(const std::vector<TargetDetection>& views, const std::vector<bool>& usable,
                const CalibrationTarget& target, int width, int height, bool estimate_k3,
                bool estimate_tangential, CameraModel* cam, std::vector<PoseBlock>* poses) {
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> img;
  for (size_t v = 0; v < views.size(); ++v) {
    if (!usable[v]) continue;
    obj.emplace_back();
    img.emplace_back();
    for (const auto& f : views[v].features) {
      const Vec3 p = target.FeatureCentre(f.row, f.col);
      obj.back().emplace_back(p.x(), p.y(), 0.f);
      img.back().emplace_back(f.centre_px.x(), f.centre_px.y());
    }
  }
  if (obj.size() < 2) return false;
  // OpenCV's calibrateCamera on the raw centres: homography initialisation (Zhang) plus its own
  // refinement, a robust start even under heavy distortion. Our refinement follows.
  cv::Mat k, dist;
  std::vector<cv::Mat> rvecs, tvecs;
  int flags = 0;
  if (!estimate_k3) flags |= cv::CALIB_FIX_K3;
  if (!estimate_tangential) flags |= cv::CALIB_ZERO_TANGENT_DIST;
  try {
    cv::calibrateCamera(obj, img, cv::Size(width, height), k, dist, rvecs, tvecs, flags);
  } catch (const cv::Exception&) {
    return false;
  }
  *cam = CameraModel();
  cam->width = width;
  cam->height = height;
  cam->fx = k.at<double>(0, 0);
  cam->fy = k.at<double>(1, 1);
  cam->cx = k.at<double>(0, 2);
  cam->cy = k.at<double>(1, 2);
  std::array<double, 5> d{};
  for (int i = 0; i < std::min<int>(5, dist.total()); ++i) d[i] = dist.at<double>(i);
  cam->SetDistortion(d);
  poses->assign(views.size(), PoseBlock{});
  size_t i = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    if (!usable[v]) continue;
    (*poses)[v] = {rvecs[i].at<double>(0), rvecs[i].at<double>(1), rvecs[i].at<double>(2),
                   tvecs[i].at<double>(0), tvecs[i].at<double>(1), tvecs[i].at<double>(2)};
    ++i;
  }
  return cam->fx > 0 && cam->fy > 0 && std::isfinite(cam->fx);
}

std::string ViewName(const std::vector<std::string>& names, size_t v) {
  return v < names.size() ? names[v] : util::StrCat("view ", v);
}

// Solve, re-measure circular centres, reject bad views / outlier features; repeated. The
// last solve follows the last change, so the result is a solver optimum of the final
// observations (its termination decides success).
void RunRounds(Bundle* b, const std::vector<const CalibrationTarget*>& targets_per_device,
               const CalibrationOptions& options, CalibrationSummary* s) {
  const CalibrationTarget& target = *targets_per_device[0];
  s->initial_rms_px = b->Rms();
  const int rounds = IsCircular(target) ? options.centre_rounds : 0;
  bool changed = true;
  for (int round = 0; round <= rounds + 2 && changed; ++round) {
    s->solve = b->Solve();
    s->iterations += s->solve.iterations;
    changed = false;
    // Bad views.
    std::vector<double> view_rms(b->reference_from_board.size(), 0);
    std::vector<int> view_n(b->reference_from_board.size(), 0);
    for (const auto& o : b->obs) {
      if (!b->Counts(o)) continue;
      view_rms[o.view] += (b->Project(o) - o.px).squaredNorm();
      ++view_n[o.view];
    }
    std::vector<double> rms_list;
    for (size_t v = 0; v < view_rms.size(); ++v) {
      if (view_n[v] > 0) {
        view_rms[v] = std::sqrt(view_rms[v] / view_n[v]);
        rms_list.push_back(view_rms[v]);
      }
    }
    std::sort(rms_list.begin(), rms_list.end());
    const double median = rms_list.empty() ? 0 : rms_list[rms_list.size() / 2];
    const double limit = std::max(options.max_image_rms_px, 3 * median);
    int used = 0;
    for (size_t v = 0; v < view_rms.size(); ++v) used += view_n[v] > 0 ? 1 : 0;
    for (size_t v = 0; v < view_rms.size(); ++v) {
      if (options.reject_outlier_views && view_n[v] > 0 && view_rms[v] > limit &&
          used > options.min_views) {
        b->view_used[v] = false;
        s->views[v].used = false;
        s->views[v].message = util::StrCat(
            "rejected: RMS ", view_rms[v], " px is an outlier among the poses (limit ", limit,
            " px = max(", options.max_image_rms_px, " px, 3 x the median pose RMS ", median,
            " px)); the calibration was redone without it");
        --used;
        changed = true;
      }
    }
    // Outlier features.
    const double rms = b->Rms();
    for (auto& o : b->obs) {
      if (!b->Counts(o)) continue;
      const double e = (b->Project(o) - o.px).norm();
      if (e > std::max(options.outlier_sigma * rms, 1.0)) {
        o.active = false;
        changed = true;
      }
    }
    // Re-measure circular centres with the current model.
    if (round < rounds) {
      for (auto& o : b->obs) {
        if (o.feature == nullptr) continue;
        Vec2 c;
        if (RemeasureCentre(*o.feature, *targets_per_device[o.device], b->devices[o.device],
                            b->DeviceFromBoard(o.device, o.view), &c)) {
          o.px = c;
        }
      }
      changed = true;
    }
  }
  if (changed) {
    s->solve = b->Solve();
    s->iterations += s->solve.iterations;
  }
  s->final_rms_px = b->Rms();
}

void FillCameraResult(const Bundle& b, int cam, const std::vector<TargetDetection>& views,
                      CameraCalibration* out) {
  out->camera = b.devices[cam];
  out->camera_from_board.assign(views.size(), Rigid3d());
  out->centres_px.assign(views.size(), {});
  out->residuals_px.assign(views.size(), {});
  for (size_t v = 0; v < views.size(); ++v) {
    if (b.view_used[v]) out->camera_from_board[v] = b.DeviceFromBoard(cam, static_cast<int>(v));
  }
  std::vector<double> ss(views.size(), 0), mx(views.size(), 0);
  std::vector<int> n(views.size(), 0);
  for (const auto& o : b.obs) {
    if (o.device != cam || !b.view_used[o.view]) continue;
    const Vec2 r = o.px - b.Project(o);
    out->centres_px[o.view].push_back(o.px);
    out->residuals_px[o.view].push_back(r);
    if (!o.active) continue;
    ss[o.view] += r.squaredNorm();
    mx[o.view] = std::max(mx[o.view], r.norm());
    ++n[o.view];
  }
  for (size_t v = 0; v < views.size(); ++v) {
    auto& vr = out->summary.views[v];
    vr.num_features = n[v];
    vr.rms_px = n[v] ? std::sqrt(ss[v] / n[v]) : 0;
    vr.max_px = mx[v];
  }
  if (cam < static_cast<int>(b.std_intrinsics.size())) out->std_dev = b.std_intrinsics[cam];
}

// Which of fx fy cx cy k1 k2 p1 p2 k3 the refinement estimates (the rest stay fixed).
FreeIntrinsics FreeIntrinsicsOf(const CalibrationOptions& options) {
  return {true,
          true,
          true,
          true,
          true,
          true,
          options.estimate_tangential,
          options.estimate_tangential,
          options.estimate_k3};
}

void Configure(const CalibrationOptions& options, Bundle* b) {
  b->free_intrinsics = FreeIntrinsicsOf(options);
  b->loss = options.loss;
  b->loss_scale_px = options.loss_scale_px;
  b->solve_options.max_iterations = options.max_iterations;
}

// Success needs enough views and a converged final solve; the message says what failed.
void Conclude(int num_views_used, int min_views, CalibrationSummary* s) {
  if (num_views_used < min_views) {
    s->status = CalibrationStatus::kTooFewViews;
    if (s->message.empty()) {
      s->message = util::StrCat("too few views left after rejection (", num_views_used, ", need ",
                                min_views, ")");
    }
  } else if (!s->solve.converged()) {
    s->status = CalibrationStatus::kNotConverged;
    s->message = util::StrCat("solver did not converge: ", s->solve.BriefReport());
  } else if (!std::isfinite(s->final_rms_px)) {
    s->status = CalibrationStatus::kNotFinite;
    s->message = "reprojection RMS not finite";
  } else {
    s->status = CalibrationStatus::kSuccess;
  }
}

// Observation k of a device's view for a joint solve, starting from the single-device
// calibration's re-measured centre (`centres`, in detection order) when there is one.
Obs JointObservation(const FeatureObservation& f, int device, int view,
                     const CalibrationTarget& target, const std::vector<Vec2>& centres, size_t k) {
  Obs o;
  o.device = device;
  o.view = view;
  o.board_point = target.FeatureCentre(f.row, f.col);
  o.px = k < centres.size() ? centres[k] : f.centre_px;
  o.feature = f.outer_edge_px.empty() ? nullptr : &f;
  return o;
}

// The transform with the smallest summed distance to the others (a robust medoid of per-view
// estimates of one rigid transform; 1 rad counts as 100 mm).
const Rigid3d& MedoidTransform(const std::vector<Rigid3d>& estimates) {
  size_t best = 0;
  double best_d = 1e300;
  for (size_t i = 0; i < estimates.size(); ++i) {
    double d = 0;
    for (size_t j = 0; j < estimates.size(); ++j) {
      const auto diff = Difference(estimates[i], estimates[j]);
      d += diff.translation_mm + 100 * diff.angle_rad;
    }
    if (d < best_d) {
      best_d = d;
      best = i;
    }
  }
  return estimates[best];
}

}  // namespace

CameraCalibration CalibrateCamera(const std::vector<TargetDetection>& views,
                                  const CalibrationTarget& target, int width, int height,
                                  const CalibrationOptions& options,
                                  const std::vector<std::string>& names) {
  options.Check();
  target.Check();
  CameraCalibration out;
  auto& s = out.summary;
  s.views.resize(views.size());
  std::vector<bool> usable(views.size(), false);
  int n_usable = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    s.views[v].name = ViewName(names, v);
    if (!views[v].ok()) {
      s.views[v].message = "target not detected: " + views[v].message;
    } else if (static_cast<int>(views[v].features.size()) < options.min_features) {
      s.views[v].message = util::StrCat("only ", views[v].features.size(), " features");
    } else {
      usable[v] = true;
      s.views[v].used = true;
      ++n_usable;
    }
  }
  if (n_usable < options.min_views) {
    s.status = CalibrationStatus::kTooFewViews;
    s.message = util::StrCat("only ", n_usable, " usable views (need ", options.min_views, ")");
    return out;
  }
  Bundle b;
  b.devices.resize(1);
  b.device_from_reference.assign(1, PoseBlock{});
  if (!Initialise(views, usable, target, width, height, options.estimate_k3,
                  options.estimate_tangential, &b.devices[0], &b.reference_from_board)) {
    s.status = CalibrationStatus::kInitialisationFailed;
    s.message = "initialisation failed";
    return out;
  }
  b.view_used = usable;
  Configure(options, &b);
  for (size_t v = 0; v < views.size(); ++v) {
    if (!usable[v]) continue;
    for (const auto& f : views[v].features) {
      Obs o;
      o.view = static_cast<int>(v);
      o.board_point = target.FeatureCentre(f.row, f.col);
      o.px = f.centre_px;
      o.feature = f.outer_edge_px.empty() ? nullptr : &f;
      b.obs.push_back(o);
    }
  }
  RunRounds(&b, {&target}, options, &s);
  FillCameraResult(b, 0, views, &out);
  s.num_views_used = 0;
  s.num_views_rejected = 0;
  s.num_features = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    if (b.view_used[v]) ++s.num_views_used;
    if (usable[v] && !b.view_used[v]) ++s.num_views_rejected;
    s.num_features += s.views[v].num_features;
  }
  Conclude(s.num_views_used, options.min_views, &s);
  return out;
}

StereoCalibration CalibrateStereo(const std::vector<TargetDetection>& left,
                                  const std::vector<TargetDetection>& right,
                                  const CalibrationTarget& target, int width, int height,
                                  const CalibrationOptions& options,
                                  const std::vector<std::string>& names, int right_width,
                                  int right_height) {
  options.Check();
  if (left.size() != right.size()) {
    throw Error(util::StrCat("CalibrateStereo: ", left.size(), " left views but ", right.size(),
                             " right views"));
  }
  StereoCalibration out;
  out.left = CalibrateCamera(left, target, width, height, options, names);
  out.right = CalibrateCamera(right, target, right_width > 0 ? right_width : width,
                              right_height > 0 ? right_height : height, options, names);
  auto& s = out.summary;
  s.views = out.left.summary.views;
  if (!out.left.summary.ok() || !out.right.summary.ok()) {
    s.status = CalibrationStatus::kCameraFailed;
    s.message =
        util::StrCat("single-camera calibration failed: left ", out.left.summary.BriefReport(),
                     "; right ", out.right.summary.BriefReport());
    return out;
  }
  // Pairs used by both cameras.
  std::vector<bool> pair(left.size(), false);
  std::vector<Rigid3d> rel;
  for (size_t v = 0; v < left.size(); ++v) {
    pair[v] = out.left.summary.views[v].used && out.right.summary.views[v].used;
    if (!pair[v]) {
      s.views[v].used = false;
      if (s.views[v].message.empty()) s.views[v].message = "not usable in both cameras";
      continue;
    }
    rel.push_back(out.right.camera_from_board[v] * out.left.camera_from_board[v].Inverse());
    ++out.num_pairs;
  }
  if (out.num_pairs < 1) {
    s.status = CalibrationStatus::kTooFewViews;
    s.message = "no view pair usable in both cameras";
    return out;
  }
  // Initial right_from_left: a robust medoid of the per-pair estimates.
  Bundle b;
  b.devices = {out.left.camera, out.right.camera};
  b.device_from_reference = {PoseBlock{}, PoseBlockOf(MedoidTransform(rel))};
  Configure(options, &b);
  b.want_covariance = true;  // rig_covariance: the predicted measurement uncertainty
  b.view_used = pair;
  b.reference_from_board.assign(left.size(), PoseBlock{});
  for (size_t v = 0; v < left.size(); ++v) {
    if (pair[v]) b.reference_from_board[v] = PoseBlockOf(out.left.camera_from_board[v]);
  }
  // obs_index[cam][view][feature] -> index into b.obs (-1: none), for the epipolar statistics.
  std::vector<std::vector<int>> obs_index[2];
  for (int cam = 0; cam < 2; ++cam) {
    const auto& views = cam == 0 ? left : right;
    const auto& centres = cam == 0 ? out.left.centres_px : out.right.centres_px;
    obs_index[cam].resize(views.size());
    for (size_t v = 0; v < views.size(); ++v) {
      obs_index[cam][v].assign(views[v].features.size(), -1);
      if (!pair[v]) continue;
      for (size_t k = 0; k < views[v].features.size(); ++k) {
        obs_index[cam][v][k] = static_cast<int>(b.obs.size());
        b.obs.push_back(JointObservation(views[v].features[k], cam, static_cast<int>(v), target,
                                         centres[v], k));
      }
    }
  }
  CalibrationOptions joint = options;
  joint.centre_rounds = std::min(options.centre_rounds, 1);
  RunRounds(&b, {&target, &target}, joint, &s);
  out.rms_px = s.final_rms_px;
  // Per-camera results from the joint solution.
  CameraCalibration l = out.left, r = out.right;
  l.summary.views = s.views;
  r.summary.views = s.views;
  FillCameraResult(b, 0, left, &l);
  FillCameraResult(b, 1, right, &r);
  l.summary.status = r.summary.status = CalibrationStatus::kSuccess;
  out.left = l;
  out.right = r;
  out.rig.left = b.devices[0];
  out.rig.right = b.devices[1];
  out.rig.right_from_left = RigidFromPoseBlock(b.device_from_reference[1].data());
  out.extrinsic_std_dev = b.std_device_from_reference[1];
  if (b.std_dev_ok && b.covariance.rows() == 2 * kNumIntrinsics + kPoseBlockSize) {
    out.rig_covariance = b.covariance;
  }
  out.left_from_board.assign(left.size(), Rigid3d());
  for (size_t v = 0; v < left.size(); ++v) {
    if (b.view_used[v]) out.left_from_board[v] = b.DeviceFromBoard(0, static_cast<int>(v));
  }
  // Epipolar distances of matched features (same view, same grid position), in the right
  // image: distance of the right point from the epipolar line of the left one.
  const Rigid3d& rfl = out.rig.right_from_left;
  Eigen::Matrix3d tx;
  const Vec3 t = rfl.translation();
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  const Eigen::Matrix3d e = tx * rfl.rotation_matrix();
  double ss = 0;
  int n = 0;
  for (size_t v = 0; v < left.size(); ++v) {
    if (!b.view_used[v]) continue;
    for (size_t i = 0; i < left[v].features.size(); ++i) {
      const auto& fl = left[v].features[i];
      for (size_t j = 0; j < right[v].features.size(); ++j) {
        const auto& fr = right[v].features[j];
        if (fr.row != fl.row || fr.col != fl.col) continue;
        // Only pairs whose observations both stayed in the solution (outliers excluded).
        const int il = obs_index[0][v][i], ir = obs_index[1][v][j];
        if (il < 0 || ir < 0 || !b.obs[il].active || !b.obs[ir].active) continue;
        const Vec2 pl =
            i < out.left.centres_px[v].size() ? out.left.centres_px[v][i] : fl.centre_px;
        const Vec2 pr =
            j < out.right.centres_px[v].size() ? out.right.centres_px[v][j] : fr.centre_px;
        const Vec3 xl = out.rig.left.Unproject(pl).homogeneous();
        const Vec3 xr = out.rig.right.Unproject(pr).homogeneous();
        const Vec3 line = e * xl;
        const double d = std::abs(xr.dot(line)) / line.head<2>().norm() * out.rig.right.fx;
        ss += d * d;
        out.epipolar_max_px = std::max(out.epipolar_max_px, d);
        ++n;
      }
    }
  }
  out.epipolar_rms_px = n ? std::sqrt(ss / n) : 0;
  s.num_views_used = 0;
  for (size_t v = 0; v < left.size(); ++v) s.num_views_used += b.view_used[v] ? 1 : 0;
  s.num_views_rejected = out.num_pairs - s.num_views_used;
  s.num_features = b.NumActive();
  // Each camera had min_views alone; the extrinsics need one common view.
  Conclude(s.num_views_used, 1, &s);
  return out;
}

MultiDeviceCalibration CalibrateDevices(const std::vector<std::vector<TargetDetection>>& views,
                                        const CalibrationTarget& target,
                                        const std::vector<cv::Size>& sizes,
                                        const CalibrationOptions& options,
                                        const std::vector<std::string>& names) {
  options.Check();
  const size_t num_devices = views.size();
  if (num_devices < 2 || sizes.size() != num_devices) {
    throw Error(util::StrCat("CalibrateDevices: ", num_devices, " devices (need >= 2) and ",
                             sizes.size(), " image sizes"));
  }
  const size_t num_views = views[0].size();
  for (const auto& v : views) {
    if (v.size() != num_views) {
      throw Error(util::StrCat("CalibrateDevices: ", v.size(), " views for one device but ",
                               num_views, " for the first"));
    }
  }
  MultiDeviceCalibration out;
  auto& s = out.summary;
  for (size_t d = 0; d < num_devices; ++d) {
    out.devices.push_back(
        CalibrateCamera(views[d], target, sizes[d].width, sizes[d].height, options, names));
  }
  s.views = out.devices[0].summary.views;
  for (size_t d = 0; d < num_devices; ++d) {
    if (!out.devices[d].summary.ok()) {
      s.message =
          util::StrCat("device ", d, " alone failed: ", out.devices[d].summary.BriefReport());
      return out;
    }
  }
  // Poses used by the reference and at least one other device; per device its relative poses.
  std::vector<bool> used(num_views, false);
  std::vector<std::vector<bool>> seen(num_devices, std::vector<bool>(num_views, false));
  Bundle b;
  b.device_from_reference.assign(num_devices, PoseBlock{});
  for (size_t d = 0; d < num_devices; ++d) {
    b.devices.push_back(out.devices[d].camera);
    for (size_t v = 0; v < num_views; ++v) seen[d][v] = out.devices[d].summary.views[v].used;
  }
  for (size_t d = 1; d < num_devices; ++d) {
    std::vector<Rigid3d> rel;
    for (size_t v = 0; v < num_views; ++v) {
      if (!seen[0][v] || !seen[d][v]) continue;
      used[v] = true;
      rel.push_back(out.devices[d].camera_from_board[v] *
                    out.devices[0].camera_from_board[v].Inverse());
    }
    if (rel.empty()) {
      s.message = util::StrCat("no view usable by both device 0 and device ", d);
      return out;
    }
    b.device_from_reference[d] = PoseBlockOf(MedoidTransform(rel));
  }
  Configure(options, &b);
  b.view_used = used;
  b.reference_from_board.assign(num_views, PoseBlock{});
  for (size_t v = 0; v < num_views; ++v) {
    if (used[v]) b.reference_from_board[v] = PoseBlockOf(out.devices[0].camera_from_board[v]);
    if (!used[v]) {
      s.views[v].used = false;
      if (s.views[v].message.empty()) s.views[v].message = "not usable by two devices";
    }
  }
  for (size_t d = 0; d < num_devices; ++d) {
    for (size_t v = 0; v < num_views; ++v) {
      if (!used[v] || !seen[d][v]) continue;
      const auto& centres = out.devices[d].centres_px;
      for (size_t k = 0; k < views[d][v].features.size(); ++k) {
        b.obs.push_back(JointObservation(views[d][v].features[k], static_cast<int>(d),
                                         static_cast<int>(v), target, centres[v], k));
      }
    }
  }
  CalibrationOptions joint = options;
  joint.centre_rounds = std::min(options.centre_rounds, 1);
  RunRounds(&b, std::vector<const CalibrationTarget*>(num_devices, &target), joint, &s);
  out.rms_px = s.final_rms_px;
  out.extrinsic_std_dev.assign(num_devices, {});
  out.device_rms_px.assign(num_devices, 0);
  for (size_t d = 0; d < num_devices; ++d) {
    CameraCalibration& c = out.devices[d];
    c.summary.views = s.views;
    FillCameraResult(b, static_cast<int>(d), views[d], &c);
    c.summary.status = s.status;  // each device shares the joint solve's outcome
    out.device_from_reference.push_back(
        d == 0 ? Rigid3d() : RigidFromPoseBlock(b.device_from_reference[d].data()));
    if (d < b.std_device_from_reference.size()) {
      out.extrinsic_std_dev[d] = b.std_device_from_reference[d];
    }
  }
  std::vector<double> ss(num_devices, 0);
  std::vector<int> n(num_devices, 0);
  for (const auto& o : b.obs) {
    if (!b.Counts(o)) continue;
    const double e2 = (b.Project(o) - o.px).squaredNorm();
    ss[o.device] += e2;
    ++n[o.device];
  }
  for (size_t d = 0; d < num_devices; ++d) {
    out.device_rms_px[d] = n[d] ? std::sqrt(ss[d] / n[d]) : 0;
  }
  out.reference_from_board.assign(num_views, Rigid3d());
  s.num_views_used = 0;
  for (size_t v = 0; v < num_views; ++v) {
    if (b.view_used[v]) {
      out.reference_from_board[v] = b.DeviceFromBoard(0, static_cast<int>(v));
      ++s.num_views_used;
    }
  }
  s.num_features = b.NumActive();
  Conclude(s.num_views_used, 1, &s);
  return out;
}

}  // namespace fringe::calib
