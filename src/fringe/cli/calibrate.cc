// fringe calibrate DIR --target target.json --out calibration.json: camera / stereo calibration
// from board images (calib/calibrate_folder.h), or camera + projector calibration when DIR holds,
// per board pose, a folder with the plain board image and the fringe stacks of both directions
// (calib/projector.h; layout in docs/scan-folder.md).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "fringe/calib/calibrate_folder.h"
#include "fringe/calib/projector.h"
#include "fringe/cli/cli.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/stack_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/log.h"

namespace fringe::cli {

namespace {
namespace fs = std::filesystem;

struct CalibrateArgs {
  std::string dir, target, out, residual_image, centres;
  bool k3 = false;
};

// Board-pose folders of the camera + projector layout: DIR/NNN/ with vertical/ and horizontal/.
std::vector<fs::path> ProjectorPoseFolders(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.is_directory() && fs::is_directory(e.path() / "vertical") &&
        fs::is_directory(e.path() / "horizontal")) {
      out.push_back(e.path());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

// One fringe stack of a pose: its manifest's scheme (of the expected direction), decoded.
phase::DecodeResult DecodePoseStack(const fs::path& stack, phase::FringeDirection direction,
                                    int* projector_width, int* projector_height) {
  const phase::PatternScheme scheme = phase::ReadScheme(stack / "manifest.json");
  if (scheme.direction != direction) {
    throw Error(util::StrCat(stack.string(), "/manifest.json: scheme '", scheme.name, "' has ",
                             phase::DirectionName(scheme.direction), " fringes; this folder needs ",
                             phase::DirectionName(direction), " ones"));
  }
  if (*projector_width == 0) {
    *projector_width = scheme.projector_width;
    *projector_height = scheme.projector_height;
  } else if (scheme.projector_width != *projector_width ||
             scheme.projector_height != *projector_height) {
    throw Error(util::StrCat(stack.string(), "/manifest.json: projector ", scheme.projector_width,
                             "x", scheme.projector_height, " differs from the other poses' ",
                             *projector_width, "x", *projector_height));
  }
  return phase::Decode(scheme, phase::ReadStack(stack, scheme));
}

// Camera + projector calibration of the pose folders; writes the rig (camera + projector).
void CalibrateProjectorFolder(const CalibrateArgs& a, const std::vector<fs::path>& poses,
                              const CalibrationTarget& target,
                              const calib::CalibrationOptions& options) {
  std::vector<calib::TargetDetection> camera;
  std::vector<calib::ProjectorCoordinates> coordinates;
  std::vector<std::string> names;
  int width = 0, height = 0, projector_width = 0, projector_height = 0;
  util::Progress progress("decode", static_cast<int>(poses.size()));
  for (const fs::path& pose : poses) {
    const auto images = io::ListImageFiles(pose);
    if (images.size() != 1) {
      throw Error(util::StrCat(pose.string(),
                               ": needs exactly one plain board image beside "
                               "vertical/ and horizontal/ (found ",
                               images.size(), ")"));
    }
    const cv::Mat board = io::ReadGrayImage(
        pose / images[0],
        width > 0 ? std::optional<cv::Size>(cv::Size(width, height)) : std::nullopt);
    width = board.cols;
    height = board.rows;
    camera.push_back(calib::DetectTarget(board, target));
    const phase::DecodeResult u = DecodePoseStack(
        pose / "vertical", phase::FringeDirection::kVertical, &projector_width, &projector_height);
    const phase::DecodeResult v =
        DecodePoseStack(pose / "horizontal", phase::FringeDirection::kHorizontal, &projector_width,
                        &projector_height);
    if (u.mask.cols != width || u.mask.rows != height || v.mask.size() != u.mask.size()) {
      throw Error(util::StrCat(pose.string(),
                               ": the fringe images are not the size of the board "
                               "image (",
                               width, "x", height, ")"));
    }
    coordinates.push_back({u.absolute_phase, v.absolute_phase, u.mask, v.mask});
    names.push_back(pose.filename().string());
    progress.Advance();
  }
  const calib::ProjectorCalibration cal =
      calib::CalibrateCameraProjector(camera, coordinates, target, width, height, projector_width,
                                      projector_height, options, {}, names);
  if (!cal.ok()) {
    throw Error(util::StrCat(
        a.dir, ": camera + projector calibration failed: ", cal.joint.summary.message));
  }
  std::cout << cal.BriefReport() << "\n";
  const Rigid3d& t = cal.rig.projector_from_left;
  std::cout << "projector_from_camera: rotation " << t.AngleRad() * 180 / M_PI << " deg, t = ("
            << t.translation().transpose() << ") mm\n";
  auto std_json = [](const calib::CameraCalibration& c) {
    return nlohmann::json{{"fx", c.std_dev[0]}, {"fy", c.std_dev[1]}, {"cx", c.std_dev[2]},
                          {"cy", c.std_dev[3]}, {"k1", c.std_dev[4]}, {"k2", c.std_dev[5]},
                          {"p1", c.std_dev[6]}, {"p2", c.std_dev[7]}, {"k3", c.std_dev[8]}};
  };
  const auto& e = cal.joint.extrinsic_std_dev;
  const nlohmann::json extra = {
      {"calibration",
       {{"rms_px", cal.joint.rms_px},
        {"camera_rms_px", cal.camera_rms_px},
        {"projector_rms_px", cal.projector_rms_px},
        {"poses", cal.joint.num_pairs},
        {"std_dev", {{"left", std_json(cal.joint.left)}, {"projector", std_json(cal.joint.right)}}},
        {"projector_from_left_std_dev",
         {{"rotation_rad", {e[0], e[1], e[2]}}, {"translation_mm", {e[3], e[4], e[5]}}}}}}};
  util::OutputTransaction outputs;
  io::WriteRig(outputs.Stage(a.out), cal.rig, extra);
  if (!a.residual_image.empty()) {
    io::WriteImage(outputs.Stage(a.residual_image), calib::ResidualImage(cal.joint.left));
  }
  if (!a.centres.empty()) {
    // The camera's detections (the projector's "centres" are decoded phase, not detections).
    calib::FolderCalibration camera_only;
    camera_only.names = names;
    camera_only.left = camera;
    camera_only.mono = cal.joint.left;
    calib::WriteCentres(outputs.Stage(a.centres), camera_only, target);
  }
  outputs.Commit();
  std::cout << "wrote " << a.out << "\n";
  if (!a.residual_image.empty()) std::cout << "wrote " << a.residual_image << "\n";
  if (!a.centres.empty()) std::cout << "wrote " << a.centres << "\n";
}

}  // namespace

void AddCalibrateCommand(CLI::App& app) {
  auto a = std::make_shared<CalibrateArgs>();
  CLI::App* sub = app.add_subcommand(
      "calibrate",
      "Calibrate a camera or a stereo pair from board images (DIR with left/ and right/, or "
      "one camera's images), or a camera + projector (DIR/NNN/ per board pose: the board image, "
      "vertical/ and horizontal/ fringe stacks with their manifests)");
  sub->add_option("dir", a->dir, "Image folder")->required();
  sub->add_option("--target", a->target, "Calibration target JSON (docs/formats.md)")->required();
  sub->add_option("--out", a->out, "Output calibration JSON (rig format)")->required();
  sub->add_option("--residual-image", a->residual_image,
                  "Write an image of residual vectors and coverage (left camera)");
  sub->add_flag("--k3", a->k3, "Also estimate the radial coefficient k3");
  sub->add_option("--centres", a->centres,
                  "Write every detected centre (raw and bias-corrected, per view and camera, "
                  "with the board feature index) as CSV or JSON, by the file's extension");
  sub->callback([a] {
    // Every output location is checked before the (long) computation; an output never replaces
    // an input (the target file, the images).
    const std::vector<std::filesystem::path> inputs = {a->dir, a->target};
    util::CheckOutputFile(a->out, inputs);
    if (!a->residual_image.empty()) util::CheckOutputFile(a->residual_image, inputs);
    if (!a->centres.empty()) {
      calib::CheckCentresPath(a->centres);
      util::CheckOutputFile(a->centres, inputs);
    }
    util::CheckDistinctOutputs({a->out, a->residual_image, a->centres});  // empty: not given
    const CalibrationTarget target = io::ReadTarget(a->target);
    calib::CalibrationOptions options;
    options.estimate_k3 = a->k3;
    util::RequireDirectory(a->dir, "image folder");
    const std::vector<fs::path> projector_poses = ProjectorPoseFolders(a->dir);
    if (!projector_poses.empty()) {
      CalibrateProjectorFolder(*a, projector_poses, target, options);
      return;
    }
    const auto result = calib::CalibrateFolder(a->dir, target, options);
    if (!result.success()) {
      // No report of figures that were never estimated: only the reason.
      throw Error(
          util::StrCat(a->dir, ": calibration failed: ",
                       result.stereo ? result.pair.summary.message : result.mono.summary.message));
    }
    std::cout << result.Report();
    // Both outputs are committed together or not at all.
    util::OutputTransaction outputs;
    calib::WriteFolderCalibration(outputs.Stage(a->out), result);
    if (!a->residual_image.empty()) {
      io::WriteImage(outputs.Stage(a->residual_image),
                     calib::ResidualImage(result.stereo ? result.pair.left : result.mono));
    }
    if (!a->centres.empty()) calib::WriteCentres(outputs.Stage(a->centres), result, target);
    outputs.Commit();
    std::cout << "wrote " << a->out << "\n";
    if (!a->residual_image.empty()) std::cout << "wrote " << a->residual_image << "\n";
    if (!a->centres.empty()) std::cout << "wrote " << a->centres << "\n";
  });
}

FRINGE_REGISTER_COMMAND(50, AddCalibrateCommand);

}  // namespace fringe::cli
