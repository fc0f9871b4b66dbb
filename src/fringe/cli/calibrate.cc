// fringe calibrate DIR --target target.json --out calibration.json: camera / stereo calibration
// from board images (calib/calibrate_folder.h), or camera(s) + projector calibration when DIR
// holds, per board pose, the plain board image and the fringe stacks of both directions of one
// camera (KKK/) or of two (KKK/left/, KKK/right/) (calib/projector_folder.h; layout in
// docs/scan-folder.md).
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
#include "fringe/calib/diagnostics.h"
#include "fringe/calib/projector_folder.h"
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
  std::string dir, target, out, residual_image, centres, report;
  bool k3 = false;
  bool keep_all = false;
  calib::DiagnosticsOptions diagnostics;
};

// The diagnostics: always printed (warnings and rejections are what a user must see); with
// --report, the report folder (summary.json, report.html) is written before the other outputs
// are committed.
void Diagnose(const CalibrateArgs& a, const calib::CalibrationDiagnosis& d,
              const nlohmann::json& calibration_json) {
  std::cout << d.diagnostics.BriefReport() << "\n";
  if (a.report.empty()) return;
  util::OutputFolderOptions output;
  output.inputs = {a.dir, a.target};
  calib::WriteCalibrationReport(a.report, d, calibration_json, output);
}

// Camera(s) + projector calibration of the pose folders (calib/projector_folder.h); writes the
// rig and the residual image together.
void CalibrateProjector(const CalibrateArgs& a, const CalibrationTarget& target,
                        const calib::CalibrationOptions& options) {
  calib::ProjectorFolderOptions folder_options;
  folder_options.calibration = options;
  const calib::ProjectorFolderCalibration cal =
      calib::CalibrateProjectorFolder(a.dir, target, folder_options);
  if (!cal.ok()) {
    throw Error(util::StrCat(
        a.dir, ": ",
        cal.layout == calib::ProjectorFolderLayout::kCamerasProjector ? "cameras" : "camera",
        " + projector calibration failed: ", cal.message()));
  }
  std::cout << cal.BriefReport() << "\n";
  const Rigid3d& t = cal.rig.projector_from_left;
  std::cout << "projector_from_left: rotation " << t.AngleRad() * 180 / M_PI << " deg, t = ("
            << t.translation().transpose() << ") mm\n";
  Diagnose(a, calib::DiagnoseProjectorCalibration(cal, target, a.diagnostics),
           CalibrationToJson(cal));
  util::OutputTransaction outputs;
  outputs.Write(a.out, [&](const fs::path& tmp) {
    io::WriteRig(tmp, cal.rig, {{"calibration", CalibrationToJson(cal)}});
  });
  if (!a.residual_image.empty()) {
    outputs.Write(a.residual_image, [&](const fs::path& tmp) {
      io::WriteImage(tmp, calib::ResidualImage(cal.LeftCamera()));
    });
  }
  if (!a.centres.empty()) {
    // The camera's detections (the projector's "centres" are decoded phase, not detections).
    calib::FolderCalibration camera_only;
    camera_only.names = cal.names;
    camera_only.left = cal.left_detections;
    camera_only.mono = cal.LeftCamera();
    outputs.Write(a.centres,
                  [&](const fs::path& tmp) { calib::WriteCentres(tmp, camera_only, target); });
  }
  outputs.Commit();
  std::cout << "wrote " << a.out << "\n";
  if (!a.residual_image.empty()) std::cout << "wrote " << a.residual_image << "\n";
  if (!a.centres.empty()) std::cout << "wrote " << a.centres << "\n";
  if (!a.report.empty()) std::cout << "wrote " << a.report << "\n";
}

}  // namespace

void AddCalibrateCommand(CLI::App& app) {
  auto a = std::make_shared<CalibrateArgs>();
  CLI::App* sub = app.add_subcommand(
      "calibrate",
      "Calibrate a camera or a stereo pair from board images (DIR with left/ and right/, or "
      "one camera's images), or camera(s) + projector (DIR/NNN/ per board pose: the board image, "
      "vertical/ and horizontal/ fringe stacks with their manifests; for two cameras in "
      "DIR/NNN/left/ and DIR/NNN/right/)");
  sub->add_option("dir", a->dir, "Image folder")->required();
  sub->add_option("--target", a->target, "Calibration target JSON (docs/formats.md)")->required();
  sub->add_option("--out", a->out, "Output calibration JSON (rig format)")->required();
  sub->add_option("--residual-image", a->residual_image,
                  "Write an image of residual vectors and coverage (left camera)");
  sub->add_flag("--k3", a->k3, "Also estimate the radial coefficient k3");
  sub->add_flag("--keep-all", a->keep_all,
                "Keep every usable board pose (default: poses whose RMS is an outlier among the "
                "poses are rejected, named with the reason, and the calibration redone)");
  sub->add_option("--report", a->report,
                  "Write the calibration report folder: report.html (residual vectors, coverage "
                  "maps, per-pose residuals, warnings, predicted depth uncertainty) and "
                  "summary.json");
  sub->add_option("--pixel-size-um", a->diagnostics.pixel_size_um,
                  "Sensor pixel size, um: checks that the focal length in mm is plausible");
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
    if (!a->report.empty()) {
      util::OutputFolderOptions report;
      report.inputs = inputs;
      util::CheckOutputFolder(a->report, report);
      for (const std::string& file : {a->out, a->residual_image, a->centres}) {
        if (file.empty()) continue;
        // A file inside the report folder would be lost when the folder is written.
        const fs::path rel =
            fs::weakly_canonical(file).lexically_relative(fs::weakly_canonical(a->report));
        if (!rel.empty() && *rel.begin() != "..") {
          throw Error(util::StrCat(file, ": inside the --report folder ", a->report,
                                   ", which is written as a whole"));
        }
      }
    }
    a->diagnostics.Check();
    const CalibrationTarget target = io::ReadTarget(a->target);
    calib::CalibrationOptions options;
    options.estimate_k3 = a->k3;
    options.reject_outlier_views = !a->keep_all;
    util::RequireDirectory(a->dir, "image folder");
    std::vector<fs::path> projector_poses;
    if (calib::FindProjectorPoseFolders(a->dir, &projector_poses) !=
        calib::ProjectorFolderLayout::kNone) {
      CalibrateProjector(*a, target, options);
      return;
    }
    const auto result = calib::CalibrateFolder(a->dir, target, options);
    if (!result.success()) {
      // No report of figures that were never estimated: only the reason, and, when the board
      // was not found in most images, the first detection failure and the target file, since a
      // target that does not describe the board (rows, features) is the usual cause.
      std::string detection;
      int found = 0, total = 0;
      for (const auto* cam : {&result.left, &result.right}) {
        const std::string folder = !result.stereo ? "" : cam == &result.left ? "left/" : "right/";
        for (size_t i = 0; i < cam->size(); ++i) {
          ++total;
          if ((*cam)[i].ok()) {
            ++found;
          } else if (detection.empty()) {
            detection = util::StrCat(folder, i < result.names.size() ? result.names[i] : "", ": ",
                                     (*cam)[i].message);
          }
        }
      }
      std::string hint;
      if (total > 0 && 2 * found < total) {
        hint = util::StrCat("; the board was found in ", found, " of ", total,
                            " images (first failure: ", detection, "); check that ", a->target,
                            " describes the board");
      }
      throw Error(util::StrCat(
          a->dir, ": calibration failed: ",
          result.stereo ? result.pair.summary.message : result.mono.summary.message, hint));
    }
    std::cout << result.Report();
    Diagnose(*a, calib::DiagnoseFolderCalibration(result, target, a->diagnostics),
             calib::CalibrationToJson(result));
    // Both outputs are committed together or not at all.
    util::OutputTransaction outputs;
    outputs.Write(a->out, [&](const fs::path& tmp) { calib::WriteFolderCalibration(tmp, result); });
    if (!a->residual_image.empty()) {
      outputs.Write(a->residual_image, [&](const fs::path& tmp) {
        io::WriteImage(tmp, calib::ResidualImage(result.stereo ? result.pair.left : result.mono));
      });
    }
    if (!a->centres.empty()) {
      outputs.Write(a->centres,
                    [&](const fs::path& tmp) { calib::WriteCentres(tmp, result, target); });
    }
    outputs.Commit();
    std::cout << "wrote " << a->out << "\n";
    if (!a->residual_image.empty()) std::cout << "wrote " << a->residual_image << "\n";
    if (!a->centres.empty()) std::cout << "wrote " << a->centres << "\n";
    if (!a->report.empty()) std::cout << "wrote " << a->report << "\n";
  });
}

FRINGE_REGISTER_COMMAND(50, AddCalibrateCommand);

}  // namespace fringe::cli
