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
}

std::string CalibrationSummary::BriefReport() const {
  std::ostringstream os;
  os << (success ? "success" : "FAILED") << ": RMS " << initial_rms_px << " -> " << final_rms_px
     << " px, " << num_views_used << " views used, " << num_views_rejected << " rejected, "
     << num_features << " features, " << iterations << " iterations";
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
using Vec6 = Eigen::Matrix<double, 6, 1>;

Rigid3d PoseFromVec(const Vec6& v) {
  const Vec3 w = v.head<3>();
  const double angle = w.norm();
  const Eigen::Matrix3d r = angle < 1e-300 ? Eigen::Matrix3d::Identity()
                                           : Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  return Rigid3d(r, v.tail<3>());
}

Vec6 VecFromPose(const Rigid3d& p) {
  const Eigen::AngleAxisd aa(p.rotation());
  Vec6 v;
  v.head<3>() = aa.axis() * aa.angle();
  v.tail<3>() = p.translation();
  return v;
}

std::array<double, kNumIntrinsics> IntrinsicsOf(const CameraModel& c) {
  return {c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3};
}
void SetIntrinsics(CameraModel* c, const double* x) {
  c->fx = x[0];
  c->fy = x[1];
  c->cx = x[2];
  c->cy = x[3];
  c->k1 = x[4];
  c->k2 = x[5];
  c->p1 = x[6];
  c->p2 = x[7];
  c->k3 = x[8];
}

// One feature observation in the bundle.
struct Obs {
  int cam = 0;   // 0: reference (left) camera, 1: right camera (through right_from_left)
  int view = 0;  // board pose index
  Vec3 board_point;
  Vec2 px;  // measured centre
  const FeatureObservation* feature = nullptr;
  bool active = true;
};

// Levenberg-Marquardt over intrinsics of 1-2 cameras, one pose per view, optionally
// right_from_left.
class Bundle {
 public:
  std::vector<CameraModel> cams;
  std::vector<Vec6> poses;  // cam0_from_board
  Vec6 right_from_left = Vec6::Zero();
  std::vector<bool> view_used;
  std::vector<Obs> obs;
  std::array<bool, kNumIntrinsics> free_intr{};

  Vec2 Project(const Obs& o, const std::vector<CameraModel>& c, const std::vector<Vec6>& p,
               const Vec6& rfl) const {
    Vec3 x = PoseFromVec(p[o.view]) * o.board_point;
    if (o.cam == 1) x = PoseFromVec(rfl) * x;
    if (x.z() <= 1e-6) return Vec2(1e6, 1e6);
    return c[o.cam].Project(x);
  }

  // Layout: [free intrinsics of each camera][6 per used view][6 right_from_left if 2 cams].
  void Layout() {
    intr_index_.clear();
    int n = 0;
    for (size_t c = 0; c < cams.size(); ++c) {
      for (int k = 0; k < kNumIntrinsics; ++k) {
        if (free_intr[k]) intr_index_.push_back({static_cast<int>(c), k, n++});
      }
    }
    pose_offset_.assign(poses.size(), -1);
    for (size_t v = 0; v < poses.size(); ++v) {
      if (view_used[v]) {
        pose_offset_[v] = n;
        n += 6;
      }
    }
    rfl_offset_ = cams.size() > 1 ? n : -1;
    if (cams.size() > 1) n += 6;
    num_params_ = n;
  }

  Eigen::VectorXd Pack() const {
    Eigen::VectorXd x(num_params_);
    for (const auto& ii : intr_index_) x(ii.index) = IntrinsicsOf(cams[ii.cam])[ii.k];
    for (size_t v = 0; v < poses.size(); ++v) {
      if (pose_offset_[v] >= 0) x.segment<6>(pose_offset_[v]) = poses[v];
    }
    if (rfl_offset_ >= 0) x.segment<6>(rfl_offset_) = right_from_left;
    return x;
  }
  void Unpack(const Eigen::VectorXd& x, std::vector<CameraModel>* c, std::vector<Vec6>* p,
              Vec6* rfl) const {
    *c = cams;
    *p = poses;
    *rfl = right_from_left;
    for (const auto& ii : intr_index_) {
      auto intr = IntrinsicsOf((*c)[ii.cam]);
      intr[ii.k] = x(ii.index);
      SetIntrinsics(&(*c)[ii.cam], intr.data());
    }
    for (size_t v = 0; v < poses.size(); ++v) {
      if (pose_offset_[v] >= 0) (*p)[v] = x.segment<6>(pose_offset_[v]);
    }
    if (rfl_offset_ >= 0) *rfl = x.segment<6>(rfl_offset_);
  }

  std::vector<int> ActiveObs() const {
    std::vector<int> a;
    for (size_t i = 0; i < obs.size(); ++i) {
      if (obs[i].active && view_used[obs[i].view]) a.push_back(static_cast<int>(i));
    }
    return a;
  }

  double Residuals(const Eigen::VectorXd& x, const std::vector<int>& active,
                   Eigen::VectorXd* r) const {
    std::vector<CameraModel> c;
    std::vector<Vec6> p;
    Vec6 rfl;
    Unpack(x, &c, &p, &rfl);
    r->resize(2 * active.size());
    for (size_t i = 0; i < active.size(); ++i) {
      const Obs& o = obs[active[i]];
      r->segment<2>(2 * i) = Project(o, c, p, rfl) - o.px;
    }
    return r->squaredNorm();
  }

  // Numeric Jacobian (central differences), exploiting which parameters touch which rows.
  Eigen::MatrixXd Jacobian(const Eigen::VectorXd& x, const std::vector<int>& active) const {
    const int m = 2 * static_cast<int>(active.size());
    Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(m, num_params_);
    std::vector<CameraModel> c;
    std::vector<Vec6> p;
    Vec6 rfl;
    for (int j = 0; j < num_params_; ++j) {
      const double h = 1e-6 * std::max(1.0, std::abs(x(j)));
      Eigen::VectorXd xp = x, xm = x;
      xp(j) += h;
      xm(j) -= h;
      // Which observations depend on parameter j.
      int cam = -1, view = -1;
      bool is_rfl = false;
      for (const auto& ii : intr_index_) {
        if (ii.index == j) cam = ii.cam;
      }
      for (size_t v = 0; v < pose_offset_.size(); ++v) {
        if (pose_offset_[v] >= 0 && j >= pose_offset_[v] && j < pose_offset_[v] + 6) {
          view = static_cast<int>(v);
        }
      }
      if (rfl_offset_ >= 0 && j >= rfl_offset_) is_rfl = true;
      std::vector<CameraModel> cp, cm;
      std::vector<Vec6> pp, pm;
      Vec6 rp, rm;
      Unpack(xp, &cp, &pp, &rp);
      Unpack(xm, &cm, &pm, &rm);
      for (size_t i = 0; i < active.size(); ++i) {
        const Obs& o = obs[active[i]];
        const bool touches =
            (cam >= 0 && o.cam == cam) || (view >= 0 && o.view == view) || (is_rfl && o.cam == 1);
        if (!touches) continue;
        jac.block<2, 1>(2 * i, j) = (Project(o, cp, pp, rp) - Project(o, cm, pm, rm)) / (2 * h);
      }
    }
    (void)c;
    (void)p;
    (void)rfl;
    return jac;
  }

  // Returns iterations; updates the parameters in place.
  int Solve(int max_iterations) {
    Layout();
    const std::vector<int> active = ActiveObs();
    Eigen::VectorXd x = Pack(), r;
    double cost = Residuals(x, active, &r);
    double mu = 1e-4;
    int it = 0;
    for (; it < max_iterations; ++it) {
      const Eigen::MatrixXd jac = Jacobian(x, active);
      const Eigen::MatrixXd jtj = jac.transpose() * jac;
      const Eigen::VectorXd g = jac.transpose() * r;
      bool improved = false, converged = false;
      for (int tries = 0; tries < 10; ++tries) {
        Eigen::MatrixXd a = jtj;
        a.diagonal() += mu * jtj.diagonal().cwiseMax(1e-9);
        const Eigen::VectorXd step = a.ldlt().solve(-g);
        const Eigen::VectorXd xn = x + step;
        Eigen::VectorXd rn;
        const double cn = Residuals(xn, active, &rn);
        if (std::isfinite(cn) && cn < cost) {
          converged = (cost - cn) < 1e-12 * cost || step.norm() < 1e-12 * (1 + x.norm());
          x = xn;
          r = rn;
          cost = cn;
          mu = std::max(mu / 5, 1e-12);
          improved = true;
          break;
        }
        mu *= 10;
      }
      if (!improved || converged) break;
    }
    Vec6 rfl;
    Unpack(x, &cams, &poses, &rfl);
    right_from_left = rfl;
    // Covariance of the free parameters.
    const Eigen::MatrixXd jac = Jacobian(x, active);
    const int m = static_cast<int>(r.size());
    const double sigma2 = m > num_params_ ? cost / (m - num_params_) : 0;
    const Eigen::MatrixXd jtj = jac.transpose() * jac;
    Eigen::MatrixXd cov = sigma2 * jtj.completeOrthogonalDecomposition().pseudoInverse();
    std_intr_.assign(cams.size(), {});
    for (const auto& ii : intr_index_) {
      std_intr_[ii.cam][ii.k] = std::sqrt(std::max(0.0, cov(ii.index, ii.index)));
    }
    std_rfl_ = {};
    if (rfl_offset_ >= 0) {
      for (int k = 0; k < 6; ++k) {
        std_rfl_[k] = std::sqrt(std::max(0.0, cov(rfl_offset_ + k, rfl_offset_ + k)));
      }
    }
    return it + 1;
  }

  double Rms() const {
    const auto active = ActiveObs();
    if (active.empty()) return 0;
    double ss = 0;
    for (int i : active)
      ss += (Project(obs[i], cams, poses, right_from_left) - obs[i].px).squaredNorm();
    return std::sqrt(ss / active.size());
  }

  std::vector<std::array<double, kNumIntrinsics>> std_intr_;
  std::array<double, 6> std_rfl_{};

 private:
  struct IntrIndex {
    int cam, k, index;
  };
  std::vector<IntrIndex> intr_index_;
  std::vector<int> pose_offset_;
  int rfl_offset_ = -1;
  int num_params_ = 0;
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
                bool estimate_tangential, CameraModel* cam, std::vector<Vec6>* poses) {
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
  poses->assign(views.size(), Vec6::Zero());
  size_t i = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    if (!usable[v]) continue;
    (*poses)[v] << rvecs[i].at<double>(0), rvecs[i].at<double>(1), rvecs[i].at<double>(2),
        tvecs[i].at<double>(0), tvecs[i].at<double>(1), tvecs[i].at<double>(2);
    ++i;
  }
  return cam->fx > 0 && cam->fy > 0 && std::isfinite(cam->fx);
}

std::string ViewName(const std::vector<std::string>& names, size_t v) {
  return v < names.size() ? names[v] : util::StrCat("view ", v);
}

// Solve, re-measure circular centres, reject bad views / outlier features; repeated.
void RunRounds(Bundle* b, const std::vector<const CalibrationTarget*>& targets_per_cam,
               const CalibrationOptions& options, CalibrationSummary* s) {
  const CalibrationTarget& target = *targets_per_cam[0];
  s->initial_rms_px = b->Rms();
  const int rounds = IsCircular(target) ? options.centre_rounds : 0;
  for (int round = 0; round <= rounds + 2; ++round) {
    s->iterations += b->Solve(options.max_iterations);
    bool changed = false;
    // Bad views.
    std::vector<double> view_rms(b->poses.size(), 0);
    std::vector<int> view_n(b->poses.size(), 0);
    for (const auto& o : b->obs) {
      if (!o.active || !b->view_used[o.view]) continue;
      view_rms[o.view] +=
          (b->Project(o, b->cams, b->poses, b->right_from_left) - o.px).squaredNorm();
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
      if (view_n[v] > 0 && view_rms[v] > limit && used > options.min_views) {
        b->view_used[v] = false;
        s->views[v].used = false;
        s->views[v].message = util::StrCat("rejected: RMS ", view_rms[v], " px > ", limit, " px");
        --used;
        changed = true;
      }
    }
    // Outlier features.
    const double rms = b->Rms();
    for (auto& o : b->obs) {
      if (!o.active || !b->view_used[o.view]) continue;
      const double e = (b->Project(o, b->cams, b->poses, b->right_from_left) - o.px).norm();
      if (e > std::max(options.outlier_sigma * rms, 1.0)) {
        o.active = false;
        changed = true;
      }
    }
    // Re-measure circular centres with the current model.
    if (round < rounds) {
      for (auto& o : b->obs) {
        if (o.feature == nullptr) continue;
        const CameraModel& cam = b->cams[o.cam];
        Rigid3d pose = PoseFromVec(b->poses[o.view]);
        if (o.cam == 1) pose = PoseFromVec(b->right_from_left) * pose;
        Vec2 c;
        if (RemeasureCentre(*o.feature, *targets_per_cam[o.cam], cam, pose, &c)) o.px = c;
      }
      changed = true;
    }
    if (!changed) break;
  }
  s->final_rms_px = b->Rms();
}

void FillCameraResult(const Bundle& b, int cam, const std::vector<TargetDetection>& views,
                      CameraCalibration* out) {
  out->camera = b.cams[cam];
  out->camera_from_board.assign(views.size(), Rigid3d());
  out->centres_px.assign(views.size(), {});
  out->residuals_px.assign(views.size(), {});
  const Rigid3d rfl = PoseFromVec(b.right_from_left);
  for (size_t v = 0; v < views.size(); ++v) {
    if (!b.view_used[v]) continue;
    out->camera_from_board[v] = cam == 1 ? rfl * PoseFromVec(b.poses[v]) : PoseFromVec(b.poses[v]);
  }
  std::vector<double> ss(views.size(), 0), mx(views.size(), 0);
  std::vector<int> n(views.size(), 0);
  for (const auto& o : b.obs) {
    if (o.cam != cam || !b.view_used[o.view]) continue;
    const Vec2 r = o.px - b.Project(o, b.cams, b.poses, b.right_from_left);
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
  if (cam < static_cast<int>(b.std_intr_.size())) {
    out->std_dev = b.std_intr_[cam];
  }
}

// Which of fx fy cx cy k1 k2 p1 p2 k3 the refinement estimates (the rest stay fixed).
std::array<bool, kNumIntrinsics> FreeIntrinsics(const CalibrationOptions& options) {
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
    s.message = util::StrCat("only ", n_usable, " usable views (need ", options.min_views, ")");
    return out;
  }
  Bundle b;
  b.cams.resize(1);
  if (!Initialise(views, usable, target, width, height, options.estimate_k3,
                  options.estimate_tangential, &b.cams[0], &b.poses)) {
    s.message = "initialisation failed";
    return out;
  }
  b.view_used = usable;
  b.free_intr = FreeIntrinsics(options);
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
  s.success = s.num_views_used >= options.min_views && std::isfinite(s.final_rms_px);
  if (!s.success && s.message.empty()) s.message = "too few views left after rejection";
  return out;
}

StereoCalibration CalibrateStereo(const std::vector<TargetDetection>& left,
                                  const std::vector<TargetDetection>& right,
                                  const CalibrationTarget& target, int width, int height,
                                  const CalibrationOptions& options,
                                  const std::vector<std::string>& names) {
  options.Check();
  if (left.size() != right.size()) {
    throw Error(util::StrCat("CalibrateStereo: ", left.size(), " left views but ", right.size(),
                             " right views"));
  }
  StereoCalibration out;
  out.left = CalibrateCamera(left, target, width, height, options, names);
  out.right = CalibrateCamera(right, target, width, height, options, names);
  auto& s = out.summary;
  s.views = out.left.summary.views;
  if (!out.left.summary.success || !out.right.summary.success) {
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
    s.message = "no view pair usable in both cameras";
    return out;
  }
  // Initial right_from_left: the per-pair estimate with the smallest summed distance to the
  // others (a robust medoid).
  size_t best = 0;
  double best_d = 1e300;
  for (size_t i = 0; i < rel.size(); ++i) {
    double d = 0;
    for (size_t j = 0; j < rel.size(); ++j) {
      const auto diff = Difference(rel[i], rel[j]);
      d += diff.translation_mm + 100 * diff.angle_rad;
    }
    if (d < best_d) {
      best_d = d;
      best = i;
    }
  }
  Bundle b;
  b.cams = {out.left.camera, out.right.camera};
  b.right_from_left = VecFromPose(rel[best]);
  b.free_intr = FreeIntrinsics(options);
  b.view_used = pair;
  b.poses.assign(left.size(), Vec6::Zero());
  for (size_t v = 0; v < left.size(); ++v) {
    if (pair[v]) b.poses[v] = VecFromPose(out.left.camera_from_board[v]);
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
        const auto& f = views[v].features[k];
        Obs o;
        o.cam = cam;
        o.view = static_cast<int>(v);
        o.board_point = target.FeatureCentre(f.row, f.col);
        // Start from the single-camera re-measured centres.
        o.px = k < centres[v].size() ? centres[v][k] : f.centre_px;
        o.feature = f.outer_edge_px.empty() ? nullptr : &f;
        b.obs.push_back(o);
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
  l.summary.success = r.summary.success = true;
  out.left = l;
  out.right = r;
  out.rig.left = b.cams[0];
  out.rig.right = b.cams[1];
  out.rig.right_from_left = PoseFromVec(b.right_from_left);
  out.extrinsic_std_dev = b.std_rfl_;
  out.left_from_board.assign(left.size(), Rigid3d());
  for (size_t v = 0; v < left.size(); ++v) {
    if (b.view_used[v]) out.left_from_board[v] = PoseFromVec(b.poses[v]);
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
  s.num_views_used = out.num_pairs;
  s.num_features = 0;
  for (const auto& vr : s.views) s.num_features += vr.used ? 1 : 0;
  s.num_features = static_cast<int>(b.ActiveObs().size());
  s.success = std::isfinite(out.rms_px);
  return out;
}

}  // namespace fringe::calib
