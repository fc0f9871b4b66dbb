#include "fringe/calib/projector.h"

#include <opencv2/calib3d.hpp>

#include <cmath>

#include "fringe/util/error.h"

namespace fringe::calib {

void ProjectorFeatureOptions::Check() const {
  util::CheckOption(window_radius_px >= 2 && window_radius_px <= 200, "ProjectorFeatureOptions",
                    "window_radius_px", window_radius_px, "must be in [2, 200]");
  util::CheckOption(min_points >= 8, "ProjectorFeatureOptions", "min_points", min_points,
                    "must be >= 8");
}

TargetDetection MapFeaturesToProjector(const TargetDetection& camera,
                                       const ProjectorCoordinates& uv, int projector_width,
                                       int projector_height,
                                       const ProjectorFeatureOptions& options) {
  options.Check();
  const cv::Size size = uv.u.size();
  if (uv.u.type() != CV_32F || uv.v.type() != CV_32F || uv.v.size() != size ||
      uv.u_mask.size() != size || uv.v_mask.size() != size || uv.u_mask.type() != CV_8U ||
      uv.v_mask.type() != CV_8U) {
    throw Error("MapFeaturesToProjector: u, v (CV_32F) and their masks (CV_8U) must have one size");
  }
  TargetDetection out;
  out.image_width = projector_width;
  out.image_height = projector_height;
  if (!camera.ok()) {
    out.message = "camera detection failed: " + camera.message;
    return out;
  }
  const int rad = options.window_radius_px;
  std::vector<cv::Point2d> cam_px, proj_px;
  for (const FeatureObservation& f : camera.features) {
    cam_px.clear();
    proj_px.clear();
    const int c0 = static_cast<int>(std::lround(f.centre_px.x()));
    const int r0 = static_cast<int>(std::lround(f.centre_px.y()));
    for (int r = std::max(0, r0 - rad); r <= std::min(size.height - 1, r0 + rad); ++r) {
      for (int c = std::max(0, c0 - rad); c <= std::min(size.width - 1, c0 + rad); ++c) {
        if (!uv.u_mask.at<uint8_t>(r, c) || !uv.v_mask.at<uint8_t>(r, c)) continue;
        const float u = uv.u.at<float>(r, c), v = uv.v.at<float>(r, c);
        if (!std::isfinite(u) || !std::isfinite(v)) continue;
        // Centred on the feature so that the linear system is well conditioned.
        cam_px.emplace_back(c - f.centre_px.x(), r - f.centre_px.y());
        proj_px.emplace_back(u, v);
      }
    }
    if (static_cast<int>(cam_px.size()) < options.min_points) continue;
    const cv::Mat h = cv::findHomography(cam_px, proj_px, 0);
    if (h.empty()) continue;
    // The feature centre is the window's origin: H (0, 0, 1).
    const double w = h.at<double>(2, 2);
    if (!(std::abs(w) > 1e-12)) continue;
    FeatureObservation p;
    p.row = f.row;
    p.col = f.col;
    p.centre_px = Eigen::Vector2d(h.at<double>(0, 2) / w, h.at<double>(1, 2) / w);
    if (!p.centre_px.allFinite()) continue;
    out.features.push_back(p);
  }
  out.num_candidates = static_cast<int>(camera.features.size());
  if (out.features.size() >= 4) {
    out.status = DetectionStatus::kOk;
  } else {
    out.message = util::StrCat("only ", out.features.size(), " of ", camera.features.size(),
                               " features have decoded projector coordinates around them");
  }
  return out;
}

std::string ProjectorCalibration::BriefReport() const {
  if (!ok()) return "projector calibration failed: " + joint.summary.message;
  const Rigid3d& t = rig.projector_from_left;
  return util::StrCat("projector calibration: ", joint.num_pairs, " views, projector RMS ",
                      projector_rms_px, " px, camera RMS ", camera_rms_px, " px, projector fx ",
                      rig.projector->fx, " fy ", rig.projector->fy, " cx ", rig.projector->cx,
                      " cy ", rig.projector->cy, " (std dev fx ", joint.right.std_dev[0], " cx ",
                      joint.right.std_dev[2], " cy ", joint.right.std_dev[3],
                      "), camera-projector baseline ", t.translation().norm(), " mm");
}

ProjectorCalibration CalibrateCameraProjector(const std::vector<TargetDetection>& camera_views,
                                              const std::vector<ProjectorCoordinates>& coordinates,
                                              const CalibrationTarget& target, int camera_width,
                                              int camera_height, int projector_width,
                                              int projector_height,
                                              const CalibrationOptions& options,
                                              const ProjectorFeatureOptions& feature_options,
                                              const std::vector<std::string>& names) {
  if (camera_views.size() != coordinates.size()) {
    throw Error(util::StrCat("CalibrateCameraProjector: ", camera_views.size(),
                             " camera views but ", coordinates.size(),
                             " sets of projector coordinates"));
  }
  ProjectorCalibration out;
  for (size_t i = 0; i < camera_views.size(); ++i) {
    out.projector_views.push_back(MapFeaturesToProjector(
        camera_views[i], coordinates[i], projector_width, projector_height, feature_options));
  }
  out.joint = CalibrateStereo(camera_views, out.projector_views, target, camera_width,
                              camera_height, options, names, projector_width, projector_height);
  if (!out.joint.summary.ok()) return out;
  out.rig.left = out.joint.rig.left;
  out.rig.right = out.joint.rig.left;
  out.rig.projector = out.joint.rig.right;
  out.rig.projector_from_left = out.joint.rig.right_from_left;
  // RMS per device over the joint solution's residuals.
  auto rms = [](const CameraCalibration& c) {
    double ss = 0;
    size_t n = 0;
    for (const auto& view : c.residuals_px) {
      for (const auto& r : view) {
        ss += r.squaredNorm();
        ++n;
      }
    }
    return n ? std::sqrt(ss / n) : 0.0;
  };
  out.camera_rms_px = rms(out.joint.left);
  out.projector_rms_px = rms(out.joint.right);
  return out;
}

std::string CamerasProjectorCalibration::BriefReport() const {
  if (!ok()) return "cameras + projector calibration failed: " + joint.summary.message;
  const CameraModel& p = *rig.projector;
  return util::StrCat(
      "cameras + projector calibration: ", joint.summary.num_views_used, " poses, RMS left ",
      joint.device_rms_px[0], " px, right ", joint.device_rms_px[1], " px, projector ",
      joint.device_rms_px[2], " px; projector fx ", p.fx, " fy ", p.fy, " cx ", p.cx, " cy ", p.cy,
      " (std dev fx ", joint.devices[2].std_dev[0], " cx ", joint.devices[2].std_dev[2], " cy ",
      joint.devices[2].std_dev[3], "), stereo baseline ", rig.BaselineMm(),
      " mm, camera-projector baseline ", rig.projector_from_left.translation().norm(), " mm");
}

CamerasProjectorCalibration CalibrateCamerasProjector(
    const std::vector<TargetDetection>& left, const std::vector<TargetDetection>& right,
    const std::vector<ProjectorCoordinates>& left_coordinates,
    const std::vector<ProjectorCoordinates>& right_coordinates, const CalibrationTarget& target,
    const cv::Size& left_size, const cv::Size& right_size, const cv::Size& projector_size,
    const CalibrationOptions& options, const ProjectorFeatureOptions& feature_options,
    const std::vector<std::string>& names) {
  const size_t n = left.size();
  if (right.size() != n || left_coordinates.size() != n || right_coordinates.size() != n) {
    throw Error(util::StrCat("CalibrateCamerasProjector: ", n, " left, ", right.size(),
                             " right detections, ", left_coordinates.size(), " left and ",
                             right_coordinates.size(),
                             " right sets of projector coordinates: need one of each per pose"));
  }
  CamerasProjectorCalibration out;
  for (size_t i = 0; i < n; ++i) {
    TargetDetection merged = MapFeaturesToProjector(
        left[i], left_coordinates[i], projector_size.width, projector_size.height, feature_options);
    const TargetDetection from_right =
        MapFeaturesToProjector(right[i], right_coordinates[i], projector_size.width,
                               projector_size.height, feature_options);
    if (from_right.ok()) {
      merged.features.insert(merged.features.end(), from_right.features.begin(),
                             from_right.features.end());
      merged.num_candidates += from_right.num_candidates;
      merged.status = DetectionStatus::kOk;
      merged.message.clear();
    }
    out.projector_views.push_back(std::move(merged));
  }
  out.joint = CalibrateDevices({left, right, out.projector_views}, target,
                               {left_size, right_size, projector_size}, options, names);
  if (!out.joint.ok()) return out;
  out.rig.left = out.joint.devices[0].camera;
  out.rig.right = out.joint.devices[1].camera;
  out.rig.right_from_left = out.joint.device_from_reference[1];
  out.rig.projector = out.joint.devices[2].camera;
  out.rig.projector_from_left = out.joint.device_from_reference[2];
  return out;
}

}  // namespace fringe::calib
