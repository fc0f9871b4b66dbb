// fringe convert-calib FILE... --out rig.json: an OpenCV calibration (YAML/XML, any usual key
// spelling, io/opencv_calibration.h) to fringe's rig JSON (docs/formats.md).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>

#include "fringe/cli/cli.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/opencv_calibration.h"
#include "fringe/util/files.h"

namespace fringe::cli {

void AddConvertCalibCommand(CLI::App& app) {
  struct Args {
    std::vector<std::string> files;
    std::string out;
    int width = 0, height = 0;
    int projector_width = 0, projector_height = 0;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "convert-calib",
      "Convert an OpenCV calibration (YAML/XML: two cameras + R/T, optionally a projector) to "
      "fringe's rig JSON, listing the keys it used");
  sub->add_option("files", a->files, "OpenCV YAML/XML file(s) (intrinsics and extrinsics)")
      ->required();
  sub->add_option("--out", a->out, "Output rig JSON")->required();
  sub->add_option("--width", a->width, "Camera image width when the file does not store it")
      ->check(CLI::Range(1, 1 << 15));
  sub->add_option("--height", a->height, "Camera image height when the file does not store it")
      ->check(CLI::Range(1, 1 << 15));
  sub->add_option("--projector-width", a->projector_width,
                  "Projector width when the file does not store it (e.g. SLMaster's caliInfo.yml)")
      ->check(CLI::Range(1, 1 << 15));
  sub->add_option("--projector-height", a->projector_height,
                  "Projector height when the file does not store it")
      ->check(CLI::Range(1, 1 << 15));
  sub->callback([a] {
    const std::vector<std::filesystem::path> files(a->files.begin(), a->files.end());
    util::CheckOutputFile(a->out, files);
    const io::OpenCvCalibration cv = io::ReadOpenCvCalibration(
        files, a->width, a->height, a->projector_width, a->projector_height);
    // One camera + projector (camera-projector systems) gives a rig without a right camera.
    io::WriteRig(a->out, cv.right ? cv.ToRig(a->files[0]) : cv.ToCameraProjectorRig(a->files[0]));
    std::cout << cv.Describe() << "wrote " << a->out << "\n";
  });
}

FRINGE_REGISTER_COMMAND(55, AddConvertCalibCommand);

}  // namespace fringe::cli
