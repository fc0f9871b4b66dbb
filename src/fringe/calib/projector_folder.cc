#include "fringe/calib/projector_folder.h"

#include <algorithm>
#include <optional>

#include "fringe/io/image_io.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/stack_io.h"
#include "fringe/util/error.h"
#include "fringe/util/log.h"

namespace fringe::calib {
namespace {

namespace fs = std::filesystem;

bool HasStacks(const fs::path& dir) {
  return fs::is_directory(dir / "vertical") && fs::is_directory(dir / "horizontal");
}

// One camera's pose: the plain board image detected, both stacks decoded. Sizes are checked
// against the earlier poses of the same camera (*size, *projector_size; zero until the first).
struct CameraPose {
  TargetDetection detection;
  ProjectorCoordinates coordinates;
};

phase::DecodeResult DecodeStack(const fs::path& stack, phase::FringeDirection direction,
                                const phase::DecodeOptions& options, cv::Size* projector_size) {
  const fs::path manifest = stack / "manifest.json";
  const phase::PatternScheme scheme = phase::ReadScheme(manifest);
  if (scheme.direction != direction) {
    throw Error(util::StrCat(manifest.string(), ": scheme '", scheme.name, "' has ",
                             phase::DirectionName(scheme.direction), " fringes; this folder needs ",
                             phase::DirectionName(direction), " ones"));
  }
  const cv::Size size(scheme.projector_width, scheme.projector_height);
  if (projector_size->area() == 0) {
    *projector_size = size;
  } else if (size != *projector_size) {
    throw Error(util::StrCat(manifest.string(), ": projector ", size.width, "x", size.height,
                             " differs from the other poses' ", projector_size->width, "x",
                             projector_size->height));
  }
  return phase::Decode(scheme, phase::ReadStack(stack, scheme), options);
}

CameraPose ReadCameraPose(const fs::path& dir, const CalibrationTarget& target,
                          const ProjectorFolderOptions& options, cv::Size* size,
                          cv::Size* projector_size) {
  const auto images = io::ListImageFiles(dir);
  if (images.size() != 1) {
    throw Error(util::StrCat(dir.string(),
                             ": needs exactly one plain board image beside vertical/ and "
                             "horizontal/ (found ",
                             images.size(), ")"));
  }
  const cv::Mat board = io::ReadGrayImage(
      dir / images[0], size->area() > 0 ? std::optional<cv::Size>(*size) : std::nullopt);
  *size = board.size();
  const phase::DecodeResult u = DecodeStack(dir / "vertical", phase::FringeDirection::kVertical,
                                            options.decode, projector_size);
  const phase::DecodeResult v = DecodeStack(dir / "horizontal", phase::FringeDirection::kHorizontal,
                                            options.decode, projector_size);
  if (u.mask.size() != board.size() || v.mask.size() != board.size()) {
    throw Error(util::StrCat(dir.string(),
                             ": the fringe images are not the size of the board image (",
                             board.cols, "x", board.rows, ")"));
  }
  CameraPose pose;
  pose.detection = DetectTarget(board, target, options.detection);
  pose.coordinates = {u.absolute_phase, v.absolute_phase, u.mask, v.mask};
  return pose;
}

nlohmann::json StdDevJson(const CameraCalibration& c) {
  return {{"fx", c.std_dev[0]}, {"fy", c.std_dev[1]}, {"cx", c.std_dev[2]},
          {"cy", c.std_dev[3]}, {"k1", c.std_dev[4]}, {"k2", c.std_dev[5]},
          {"p1", c.std_dev[6]}, {"p2", c.std_dev[7]}, {"k3", c.std_dev[8]}};
}

nlohmann::json ExtrinsicStdDevJson(const std::array<double, 6>& e) {
  return {{"rotation_rad", {e[0], e[1], e[2]}}, {"translation_mm", {e[3], e[4], e[5]}}};
}

}  // namespace

void ProjectorFolderOptions::Check() const {
  calibration.Check();
  features.Check();
  detection.Check();
  decode.Check();
}

ProjectorFolderLayout FindProjectorPoseFolders(const fs::path& dir, std::vector<fs::path>* poses) {
  if (!fs::is_directory(dir)) throw Error(util::StrCat(dir.string(), ": not a folder"));
  poses->clear();
  bool mono = false, stereo = false;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_directory()) continue;
    const bool m = HasStacks(e.path());
    const bool s = HasStacks(e.path() / "left") && HasStacks(e.path() / "right");
    if (!m && !s) continue;
    mono = mono || m;
    stereo = stereo || s;
    poses->push_back(e.path());
  }
  if (mono && stereo) {
    throw Error(util::StrCat(dir.string(),
                             ": some pose folders hold one camera's fringe stacks "
                             "(KKK/vertical/), others two cameras' (KKK/left/vertical/); use one "
                             "layout"));
  }
  std::sort(poses->begin(), poses->end());
  return stereo ? ProjectorFolderLayout::kCamerasProjector
         : mono ? ProjectorFolderLayout::kCameraProjector
                : ProjectorFolderLayout::kNone;
}

std::string ProjectorFolderCalibration::message() const {
  if (ok()) return "";
  return layout == ProjectorFolderLayout::kCamerasProjector
             ? cameras.joint.summary.message
             : camera_projector.joint.summary.message;
}

std::string ProjectorFolderCalibration::BriefReport() const {
  return layout == ProjectorFolderLayout::kCamerasProjector ? cameras.BriefReport()
                                                            : camera_projector.BriefReport();
}

const CameraCalibration& ProjectorFolderCalibration::LeftCamera() const {
  return layout == ProjectorFolderLayout::kCamerasProjector ? cameras.joint.devices.at(0)
                                                            : camera_projector.joint.left;
}

nlohmann::json CalibrationToJson(const ProjectorFolderCalibration& s) {
  if (s.layout == ProjectorFolderLayout::kCamerasProjector) {
    const MultiDeviceCalibration& j = s.cameras.joint;
    return {{"rms_px", j.rms_px},
            {"left_rms_px", j.device_rms_px[0]},
            {"right_rms_px", j.device_rms_px[1]},
            {"projector_rms_px", j.device_rms_px[2]},
            {"poses", j.summary.num_views_used},
            {"std_dev",
             {{"left", StdDevJson(j.devices[0])},
              {"right", StdDevJson(j.devices[1])},
              {"projector", StdDevJson(j.devices[2])}}},
            {"right_from_left_std_dev", ExtrinsicStdDevJson(j.extrinsic_std_dev[1])},
            {"projector_from_left_std_dev", ExtrinsicStdDevJson(j.extrinsic_std_dev[2])}};
  }
  const ProjectorCalibration& c = s.camera_projector;
  return {
      {"rms_px", c.joint.rms_px},
      {"camera_rms_px", c.camera_rms_px},
      {"projector_rms_px", c.projector_rms_px},
      {"poses", c.joint.num_pairs},
      {"std_dev", {{"left", StdDevJson(c.joint.left)}, {"projector", StdDevJson(c.joint.right)}}},
      {"projector_from_left_std_dev", ExtrinsicStdDevJson(c.joint.extrinsic_std_dev)}};
}

ProjectorFolderCalibration CalibrateProjectorFolder(const fs::path& dir,
                                                    const CalibrationTarget& target,
                                                    const ProjectorFolderOptions& options) {
  options.Check();
  target.Check();
  ProjectorFolderCalibration out;
  std::vector<fs::path> poses;
  out.layout = FindProjectorPoseFolders(dir, &poses);
  if (out.layout == ProjectorFolderLayout::kNone) {
    throw Error(util::StrCat(dir.string(),
                             ": no board pose folder with vertical/ and horizontal/ fringe stacks "
                             "(KKK/vertical/ or KKK/left/vertical/, docs/scan-folder.md)"));
  }
  const bool two = out.layout == ProjectorFolderLayout::kCamerasProjector;
  cv::Size left_size, right_size, projector_size;
  std::vector<TargetDetection> left, right;
  std::vector<ProjectorCoordinates> left_uv, right_uv;
  util::Progress progress("decode", static_cast<int>(poses.size()));
  for (const fs::path& pose : poses) {
    CameraPose l =
        ReadCameraPose(two ? pose / "left" : pose, target, options, &left_size, &projector_size);
    left.push_back(std::move(l.detection));
    left_uv.push_back(std::move(l.coordinates));
    if (two) {
      CameraPose r = ReadCameraPose(pose / "right", target, options, &right_size, &projector_size);
      right.push_back(std::move(r.detection));
      right_uv.push_back(std::move(r.coordinates));
    }
    out.names.push_back(pose.filename().string());
    progress.Advance();
  }
  if (two) {
    out.cameras =
        CalibrateCamerasProjector(left, right, left_uv, right_uv, target, left_size, right_size,
                                  projector_size, options.calibration, options.features, out.names);
    out.rig = out.cameras.rig;
  } else {
    out.camera_projector = CalibrateCameraProjector(
        left, left_uv, target, left_size.width, left_size.height, projector_size.width,
        projector_size.height, options.calibration, options.features, out.names);
    out.rig = out.camera_projector.rig;
  }
  out.left_detections = std::move(left);
  out.right_detections = std::move(right);
  return out;
}

}  // namespace fringe::calib
