// fringe calibrate DIR --target target.json --out calibration.json: camera / stereo calibration
// from board images (calib/calibrate_folder.h).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <vector>

#include "fringe/calib/calibrate_folder.h"
#include "fringe/cli/cli.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::cli {

namespace {
struct CalibrateArgs {
  std::string dir, target, out, residual_image;
  bool k3 = false;
};
}  // namespace

void AddCalibrateCommand(CLI::App& app) {
  auto a = std::make_shared<CalibrateArgs>();
  CLI::App* sub = app.add_subcommand(
      "calibrate",
      "Calibrate a camera or a stereo pair from board images (DIR with left/ and right/, or "
      "one camera's images)");
  sub->add_option("dir", a->dir, "Image folder")->required();
  sub->add_option("--target", a->target, "Calibration target JSON (docs/formats.md)")->required();
  sub->add_option("--out", a->out, "Output calibration JSON (rig format)")->required();
  sub->add_option("--residual-image", a->residual_image,
                  "Write an image of residual vectors and coverage (left camera)");
  sub->add_flag("--k3", a->k3, "Also estimate the radial coefficient k3");
  sub->callback([a] {
    // Every output location is checked before the (long) computation; an output never replaces
    // an input (the target file, the images).
    const std::vector<std::filesystem::path> inputs = {a->dir, a->target};
    util::CheckOutputFile(a->out, inputs);
    if (!a->residual_image.empty()) {
      util::CheckOutputFile(a->residual_image, inputs);
      util::CheckDistinctOutputs({a->out, a->residual_image});
    }
    const CalibrationTarget target = io::ReadTarget(a->target);
    calib::CalibrationOptions options;
    options.estimate_k3 = a->k3;
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
    outputs.Commit();
    std::cout << "wrote " << a->out << "\n";
    if (!a->residual_image.empty()) std::cout << "wrote " << a->residual_image << "\n";
  });
}

FRINGE_REGISTER_COMMAND(50, AddCalibrateCommand);

}  // namespace fringe::cli
