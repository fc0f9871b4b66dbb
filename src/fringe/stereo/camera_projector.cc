#include "fringe/stereo/camera_projector.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>

#include "fringe/phase/decode.h"
#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::stereo {
namespace {

constexpr int kMaxNewtonIterations = 30;

}  // namespace

CameraProjectorRig CameraProjectorRig::FromLeftCamera(const StereoRig& rig) {
  if (!rig.projector) {
    throw Error("camera-projector: the rig has no calibrated projector");
  }
  CameraProjectorRig out;
  out.camera = rig.left;
  out.projector = *rig.projector;
  out.projector_from_camera = rig.projector_from_left;
  return out;
}

void CameraProjectorRig::Check() const {
  camera.Check();
  projector.Check();
  if (!(projector_from_camera.translation().norm() > 0)) {
    throw Error("camera-projector rig: zero baseline between camera and projector");
  }
}

StereoRig CameraProjectorRig::AsTwoViewRig() const {
  StereoRig two;
  two.left = camera;
  two.right = projector;
  two.right_from_left = projector_from_camera;
  return two;
}

TriangulatedPoint TriangulateCameraProjectorRay(const CameraProjectorRig& rig,
                                                const Eigen::Vector3d& ray_in_camera,
                                                double projector_coordinate_px,
                                                phase::FringeDirection direction,
                                                const TriangulationOptions& options) {
  TriangulatedPoint out;
  const CameraModel& proj = rig.projector;
  const bool vertical = direction == phase::FringeDirection::kVertical;
  // In the projector frame: the camera centre c and the ray direction w.
  const Eigen::Vector3d c = rig.projector_from_camera.translation();
  const Eigen::Vector3d w = rig.projector_from_camera.RotateDirection(ray_in_camera);
  // Epipolar line n . (x, y, 1) = 0 in the undistorted normalized projector plane.
  const Eigen::Vector3d n = c.cross(w);
  // Along the line, the free normalized coordinate is the one the fringes measure (x for
  // columns); the other follows: y = -(n0 x + n2) / n1 (or x from y for rows).
  const double n_free = vertical ? n.x() : n.y();
  const double n_dep = vertical ? n.y() : n.x();
  if (std::abs(n_dep) < 1e-12 * n.norm()) {
    out.status = TriangulationStatus::kParallelRays;  // line along the measured coordinate
    return out;
  }
  const double slope = -n_free / n_dep, offset = -n.z() / n_dep;
  const double target = vertical ? (projector_coordinate_px - proj.cx) / proj.fx
                                 : (projector_coordinate_px - proj.cy) / proj.fy;
  // Newton on the free coordinate t: distorted(t, slope t + offset)[measured] = target.
  double t = target;
  bool converged = false;
  for (int it = 0; it < kMaxNewtonIterations; ++it) {
    const double other = slope * t + offset;
    const Eigen::Vector2d xy = vertical ? Eigen::Vector2d(t, other) : Eigen::Vector2d(other, t);
    const Eigen::Vector2d xy_d = proj.Distort(xy);
    const Eigen::Matrix2d jac = proj.DistortJacobian(xy);
    const int k = vertical ? 0 : 1;
    const double g = xy_d[k] - target;
    const double dg = vertical ? jac(0, 0) + jac(0, 1) * slope : jac(1, 1) + jac(1, 0) * slope;
    if (!(std::abs(dg) > 1e-12)) break;
    const double step = g / dg;
    t -= step;
    if (!std::isfinite(t)) break;
    if (std::abs(step) < 1e-15 * (1 + std::abs(t))) {
      converged = true;
      break;
    }
  }
  if (!converged) {
    out.status = TriangulationStatus::kParallelRays;
    return out;
  }
  const Eigen::Vector2d xy =
      vertical ? Eigen::Vector2d(t, slope * t + offset) : Eigen::Vector2d(slope * t + offset, t);
  // The projector ray through xy and the camera ray must not be (nearly) parallel.
  const Eigen::Vector3d d_proj = Eigen::Vector3d(xy.x(), xy.y(), 1).normalized();
  const Eigen::Vector3d w_unit = w.normalized();
  if (d_proj.cross(w_unit).norm() < std::sin(options.min_ray_angle_rad)) {
    out.status = TriangulationStatus::kParallelRays;
    return out;
  }
  // Depth s along the camera ray: (c + s w) projects to xy. Of the two equations
  // c_x + s w_x = x (c_z + s w_z) and the same in y, take the better conditioned one.
  const double den_x = w.x() - xy.x() * w.z(), den_y = w.y() - xy.y() * w.z();
  const double s = std::abs(den_x) >= std::abs(den_y) ? (xy.x() * c.z() - c.x()) / den_x
                                                      : (xy.y() * c.z() - c.y()) / den_y;
  const Eigen::Vector3d p_in_proj = c + s * w;
  if (!(s > 0) || !(p_in_proj.z() > 0)) {
    out.status = TriangulationStatus::kBehindCamera;
    return out;
  }
  out.status = TriangulationStatus::kOk;
  out.p_in_left = s * ray_in_camera;
  const Eigen::Vector2d back = proj.Project(p_in_proj);
  out.reprojection_error_px = std::abs((vertical ? back.x() : back.y()) - projector_coordinate_px);
  return out;
}

TriangulatedPoint TriangulateCameraProjector(const CameraProjectorRig& rig,
                                             const Eigen::Vector2d& camera_px,
                                             double projector_coordinate_px,
                                             phase::FringeDirection direction,
                                             const TriangulationOptions& options) {
  return TriangulateCameraProjectorRay(rig, rig.camera.Ray(camera_px), projector_coordinate_px,
                                       direction, options);
}

TriangulatedPoint TriangulateCameraProjector(const CameraProjectorRig& rig,
                                             const Eigen::Vector2d& camera_px,
                                             const Eigen::Vector2d& projector_px,
                                             const TriangulationOptions& options) {
  return Triangulate(rig.AsTwoViewRig(), camera_px, projector_px, options);
}

void CameraProjectorOptions::Check() const { reconstruction.Check(); }

CameraProjectorReconstructor::CameraProjectorReconstructor(
    const CameraProjectorRig& rig, const std::vector<phase::PatternScheme>& schemes,
    const CameraProjectorOptions& options)
    : rig_(rig), schemes_(schemes), options_(options) {
  rig_.Check();
  options_.Check();
  if (schemes_.empty() || schemes_.size() > 2) {
    throw Error(
        util::StrCat("camera-projector: need one or two pattern schemes, got ", schemes_.size()));
  }
  for (const auto& s : schemes_) s.Check();
  if (schemes_.size() == 2 && schemes_[0].direction == schemes_[1].direction) {
    throw Error(util::StrCat("camera-projector: the two schemes '", schemes_[0].name, "' and '",
                             schemes_[1].name, "' have the same fringe direction (",
                             phase::DirectionName(schemes_[0].direction),
                             "); two schemes must be one vertical and one horizontal"));
  }
  rays_.resize(static_cast<size_t>(rig_.camera.width) * rig_.camera.height);
  tbb::parallel_for(tbb::blocked_range<int>(0, rig_.camera.height), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      for (int c = 0; c < rig_.camera.width; ++c) {
        rays_[static_cast<size_t>(r) * rig_.camera.width + c] =
            rig_.camera.Ray(Eigen::Vector2d(c, r));
      }
    }
  });
}

ViewReconstruction CameraProjectorReconstructor::Reconstruct(
    const std::vector<std::vector<cv::Mat>>& stacks) const {
  util::Timer total;
  if (stacks.size() != schemes_.size()) {
    throw Error(util::StrCat("camera-projector: ", stacks.size(), " image stacks for ",
                             schemes_.size(), " schemes"));
  }
  const CameraModel& cam = rig_.camera;
  for (size_t i = 0; i < stacks.size(); ++i) {
    if (!stacks[i].empty() && (stacks[i][0].cols != cam.width || stacks[i][0].rows != cam.height)) {
      throw Error(util::StrCat("camera-projector: images of scheme '", schemes_[i].name, "' are ",
                               stacks[i][0].cols, "x", stacks[i][0].rows, " but the camera is ",
                               cam.width, "x", cam.height));
    }
  }
  const ReconstructionOptions& ro = options_.reconstruction;
  ViewReconstruction out;
  ReconstructionSummary& s = out.summary;
  util::Timer timer;
  std::vector<phase::DecodeResult> decoded;
  for (size_t i = 0; i < stacks.size(); ++i) {
    decoded.push_back(phase::Decode(schemes_[i], stacks[i], ro.decode));
  }
  s.decode_left = decoded[0].summary;
  if (decoded.size() > 1) s.decode_right = decoded[1].summary;
  s.decode_s = timer.ElapsedSeconds();
  // Texture on the 0-255 scale from the full scale the decoder used (reconstruct_view.cc).
  const double texture_scale = 255.0 / decoded[0].summary.full_scale_dn;
  decoded[0].background.convertTo(out.texture_left, CV_32F, texture_scale);
  out.cloud = OrganizedPointCloud(cam.width, cam.height, false, true, true);
  out.reprojection_error_px =
      cv::Mat(cam.height, cam.width, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (size_t i = 0; i < decoded.size(); ++i) {
    const phase::DecodeSummary& d = decoded[i].summary;
    if (d.status != phase::DecodeStatus::kSuccess) {
      s.status = ReconstructionStatus::kNoValidPixels;
      s.message = util::StrCat("the fringe decoder found no valid pixel in the camera images of '",
                               schemes_[i].name, "' (", d.BriefReport(), ")");
      s.total_s = total.ElapsedSeconds();
      return out;
    }
  }

  // Correspondence and triangulation per pixel; counts per row, summed in row order.
  timer.Restart();
  const bool both = decoded.size() == 2;
  const int vertical_index =
      schemes_[0].direction == phase::FringeDirection::kVertical ? 0 : (both ? 1 : -1);
  const StereoRig two_view = rig_.AsTwoViewRig();
  const MatchingOptions& mo = ro.matching;
  std::vector<int> failed(cam.height, 0), out_of_range(cam.height, 0), residual(cam.height, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, cam.height), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      for (int c = 0; c < cam.width; ++c) {
        bool valid = true;
        for (const auto& d : decoded) valid = valid && d.mask.at<uint8_t>(r, c) != 0;
        if (!valid) continue;
        const size_t i = out.cloud.index(c, r);
        TriangulatedPoint tp;
        if (both) {
          const double u = decoded[vertical_index].absolute_phase.at<float>(r, c);
          const double v = decoded[1 - vertical_index].absolute_phase.at<float>(r, c);
          const Eigen::Vector2d xy_proj = rig_.projector.Unproject(Eigen::Vector2d(u, v));
          tp = TriangulateFromRays(two_view, rays_[i], Eigen::Vector2d(c, r), xy_proj,
                                   Eigen::Vector2d(u, v), mo.triangulation);
          if (tp.ok() && tp.reprojection_error_px > mo.max_reprojection_error_px) {
            ++residual[r];
            continue;
          }
        } else {
          tp = TriangulateCameraProjectorRay(rig_, rays_[i],
                                             decoded[0].absolute_phase.at<float>(r, c),
                                             schemes_[0].direction, mo.triangulation);
        }
        if (!tp.ok()) {
          ++failed[r];
          continue;
        }
        if (tp.p_in_left.z() < mo.min_depth_mm || tp.p_in_left.z() > mo.max_depth_mm) {
          ++out_of_range[r];
          continue;
        }
        out.cloud.valid[i] = 1;
        out.cloud.cloud.points[i] = tp.p_in_left;
        out.cloud.cloud.quality[i] = decoded[0].modulation.at<float>(r, c);
        out.cloud.cloud.intensity[i] =
            static_cast<float>(decoded[0].background.at<float>(r, c) * texture_scale);
        out.reprojection_error_px.at<float>(r, c) = static_cast<float>(tp.reprojection_error_px);
      }
    }
  });
  MatchingSummary& m = s.matching;
  for (int r = 0; r < cam.height; ++r) {
    m.triangulation_failed += failed[r];
    m.out_of_depth_range += out_of_range[r];
    m.large_residual += residual[r];
  }
  m.left_valid = static_cast<int>(cv::countNonZero(decoded[0].mask));
  m.points = static_cast<int>(out.cloud.NumValid());
  double sum = 0;
  for (size_t i = 0; i < out.cloud.valid.size(); ++i) {
    if (out.cloud.valid[i]) {
      sum += out.reprojection_error_px.at<float>(static_cast<int>(i / cam.width),
                                                 static_cast<int>(i % cam.width));
    }
  }
  m.mean_reprojection_error_px = m.points ? sum / m.points : 0;
  m.time_s = timer.ElapsedSeconds();
  s.match_s = m.time_s;

  // The stages after correspondence, as in stereo mode.
  FinishViewReconstruction(cam.fx, ro, &out);
  s.total_s = total.ElapsedSeconds();
  return out;
}

}  // namespace fringe::stereo
