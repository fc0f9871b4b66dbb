#include "fringe/calib/calibration_scene.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "fringe/geometry/rigid3.h"
#include "fringe/util/error.h"

namespace fringe::calib {
namespace {

nlohmann::json Row(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// 3 x 4 row-major, as the scene format writes transforms.
nlohmann::json Matrix34(const Rigid3d& t) {
  const Eigen::Matrix3d r = t.rotation_matrix();
  nlohmann::json out = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out.push_back(r(i, j));
    out.push_back(t.translation()(i));
  }
  return out;
}

// A pose used by the reference camera (the only ones its camera_from_board places).
bool Placed(const CalibrationDiagnostics& d, const std::vector<DiagnosedDevice>& devices,
            size_t pose) {
  return pose < d.poses.size() && d.poses[pose].used &&
         pose < devices[0].calibration->camera_from_board.size() &&
         !d.poses[pose].features.empty() && d.poses[pose].features[0] > 0;
}

}  // namespace

io::ReportScene CalibrationScene(const CalibrationDiagnostics& d,
                                 const std::vector<DiagnosedDevice>& devices,
                                 const CalibrationTarget& target) {
  if (devices.empty() || !devices[0].calibration) {
    throw Error("calibration scene: no reference camera");
  }
  const CameraCalibration& reference = *devices[0].calibration;
  io::ReportScene scene;
  nlohmann::json& s = scene.description;
  s["version"] = 1;
  s["frame"] = util::StrCat(devices[0].name, " camera frame, mm");
  // The camera frame has y down and z forward; the view's z is up: display = (x, z, -y), so the
  // home view looks along the camera's axis from behind it.
  s["display_from_world"] = {1, 0, 0, 0, 0, 0, 1, 0, 0, -1, 0, 0};

  // The boards' features at every placed pose, and each pose's residual: the RMS over every
  // device's features of that pose.
  const std::vector<Eigen::Vector3d> board = target.FeatureCentres();
  const Eigen::Vector3d outline[4] = {target.FeatureCentre(0, 0),
                                      target.FeatureCentre(0, target.cols - 1),
                                      target.FeatureCentre(target.rows - 1, target.cols - 1),
                                      target.FeatureCentre(target.rows - 1, 0)};
  std::vector<Eigen::Vector3d> points;
  std::vector<uint16_t> point_pose;
  std::vector<float> point_rms;
  nlohmann::json boards = nlohmann::json::array(), board_rms = nlohmann::json::array(),
                 board_index = nlohmann::json::array(), pose_names = nlohmann::json::array();
  double worst = 0;
  for (size_t v = 0; v < d.poses.size(); ++v) {
    if (!Placed(d, devices, v)) continue;
    const PoseDiagnostics& p = d.poses[v];
    double sum_sq = 0;
    int count = 0;
    for (size_t k = 0; k < p.features.size() && k < p.rms_px.size(); ++k) {
      sum_sq += p.features[k] * p.rms_px[k] * p.rms_px[k];
      count += p.features[k];
    }
    const double rms = count > 0 ? std::sqrt(sum_sq / count) : 0.0;
    worst = std::max(worst, rms);
    const Rigid3d& camera_from_board = reference.camera_from_board[v];
    const uint16_t index = static_cast<uint16_t>(pose_names.size());
    pose_names.push_back(p.name);
    for (const Eigen::Vector3d& f : board) {
      points.push_back(camera_from_board * f);
      point_pose.push_back(index);
      point_rms.push_back(static_cast<float>(rms));
    }
    nlohmann::json corners = nlohmann::json::array();
    for (const Eigen::Vector3d& c : outline) corners.push_back(Row(camera_from_board * c));
    boards.push_back({{"name", p.name}, {"corners", corners}});
    board_rms.push_back(rms);
    board_index.push_back(index);
  }

  // Positions are float32 relative to the boards' centre.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centre += p;
  if (!points.empty()) centre = (centre / static_cast<double>(points.size())).array().round();
  s["origin"] = Row(centre);
  std::vector<float> positions;
  positions.reserve(3 * points.size());
  for (const Eigen::Vector3d& p : points) {
    for (int k = 0; k < 3; ++k) positions.push_back(static_cast<float>(p(k) - centre(k)));
  }
  if (!points.empty()) {
    scene.AddArray("points.positions", positions);
    scene.AddArray("points.pose_rms", point_rms);
    scene.AddArray("points.pose", point_pose);
    s["points"] = {
        {"positions", "points.positions"}, {"count", points.size()}, {"total", points.size()}};
  }
  s["boards"] = boards;
  s["colourings"] =
      nlohmann::json::array({{{"id", "pose_rms"},
                              {"title", "pose residual"},
                              {"label", "RMS reprojection residual of the pose (all devices), px"},
                              {"kind", "scalar"},
                              {"unit", "px"},
                              {"range", {0.0, std::max(worst, 1e-3)}},
                              {"points", "points.pose_rms"},
                              {"boards", board_rms}},
                             {{"id", "pose"},
                              {"title", "pose"},
                              {"kind", "category"},
                              {"names", pose_names},
                              {"points", "points.pose"},
                              {"boards", board_index}}});

  // The devices: device_from_reference from the first pose both used.
  s["views"] = nlohmann::json::array();
  for (size_t k = 0; k < devices.size(); ++k) {
    if (!devices[k].calibration) continue;
    const CameraCalibration& c = *devices[k].calibration;
    std::optional<Rigid3d> device_from_reference;
    if (k == 0) device_from_reference = Rigid3d::Identity();
    for (size_t v = 0; v < d.poses.size() && !device_from_reference; ++v) {
      if (Placed(d, devices, v) && k < d.poses[v].features.size() && d.poses[v].features[k] > 0 &&
          v < c.camera_from_board.size()) {
        device_from_reference = c.camera_from_board[v] * reference.camera_from_board[v].Inverse();
      }
    }
    if (!device_from_reference) continue;
    const Rigid3d reference_from_device = device_from_reference->Inverse();
    const double distance = (reference_from_device.translation() - centre).norm();
    const CameraModel& m = c.camera;
    s["views"].push_back({{"name", devices[k].name},
                          {"title", util::StrCat(devices[k].name, " (calibrated pose)")},
                          {"world_from_sensor", Matrix34(reference_from_device)},
                          {"fx", m.fx},
                          {"fy", m.fy},
                          {"cx", m.cx},
                          {"cy", m.cy},
                          {"width", m.width},
                          {"height", m.height},
                          {"depth_mm", 0.2 * distance}});
  }
  s["note"] =
      util::StrCat("Boards at the ", pose_names.size(),
                   " poses the calibration used (rejected poses have no solved pose), in the ",
                   devices[0].name, " camera's frame; the devices at their calibrated poses.");
  return scene;
}

}  // namespace fringe::calib
