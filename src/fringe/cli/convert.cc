// fringe convert-calib FILE... --out OUT [--to FORMAT]: a calibration of any format fringe reads
// (fringe's rig JSON, OpenCV YAML/XML under the usual spellings, SLStudio calibration.xml, ROS
// camera_info, Kalibr camchain, or any file through --opencv-keys; io/calibration_formats.h) to
// fringe's rig JSON (the default) or to another tool's format, listing the keys it used.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>

#include "fringe/cli/cli.h"
#include "fringe/io/calibration_formats.h"
#include "fringe/io/calibration_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::cli {

void AddConvertCalibCommand(CLI::App& app) {
  struct Args {
    std::vector<std::string> files;
    std::vector<std::string> out;
    std::string to = "rig";
    std::vector<std::string> keys;
    int width = 0, height = 0;
    int projector_width = 0, projector_height = 0;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "convert-calib",
      "Convert a calibration between fringe's rig JSON and other tools' files (OpenCV YAML/XML, "
      "SLStudio calibration.xml, ROS camera_info, Kalibr camchain), listing the keys it used");
  sub->add_option("files", a->files,
                  "Calibration file(s): a rig JSON, or another tool's file(s) (OpenCV intrinsics "
                  "+ extrinsics, ROS left + right camera_info, ...)")
      ->required();
  sub->add_option("--out", a->out,
                  "Output file (ros: two files, the left then the right camera_info)")
      ->required()
      ->expected(1, 2);
  sub->add_option("--to", a->to,
                  "Output format: rig (fringe's JSON), opencv, slstudio, ros, kalibr")
      ->check(CLI::IsMember({"rig", "opencv", "slstudio", "ros", "kalibr"}));
  sub->add_option("--opencv-keys", a->keys,
                  "Which key holds what, for files no reader recognises, e.g. left=Kc,kc "
                  "projector=Kp,kp projector_from_left=Rp,Tp left_size=frameWidth,frameHeight")
      ->expected(1, 16);
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
    const std::vector<std::filesystem::path> outs(a->out.begin(), a->out.end());
    const int expected_outs =
        a->to == "rig" ? 1 : io::CalibrationOutputCount(io::ParseCalibrationFormat(a->to));
    if (static_cast<int>(outs.size()) != expected_outs) {
      throw Error(util::StrCat("--out: --to ", a->to, " writes ", expected_outs, " file",
                               expected_outs == 1 ? "" : "s (left, right)", ", ", outs.size(),
                               " given"));
    }
    for (const auto& o : outs) util::CheckOutputFile(o, files);
    util::CheckDistinctOutputs(outs);
    // A rig JSON is fringe's own calibration, to be written in another tool's format.
    const bool rig_json = files.size() == 1 && util::HasExtension(files[0], {".json"});
    StereoRig rig;
    if (rig_json) {
      if (!a->keys.empty()) throw Error("--opencv-keys: a rig JSON has fringe's own keys");
      rig = io::ReadRig(files[0]);
      std::cout << "  format: fringe rig JSON\n";
    } else {
      io::CalibrationReadOptions o;
      o.camera_width = a->width;
      o.camera_height = a->height;
      o.projector_width = a->projector_width;
      o.projector_height = a->projector_height;
      o.keys = io::CalibrationKeyMap::Parse(a->keys);
      const io::OpenCvCalibration cv = io::ReadCalibration(files, o);
      // One camera + projector (camera-projector systems) gives a rig without a right camera.
      rig = cv.right ? cv.ToRig(a->files[0]) : cv.ToCameraProjectorRig(a->files[0]);
      std::cout << cv.Describe();
    }
    if (a->to == "rig") {
      io::WriteRig(outs[0], rig);
    } else {
      for (const std::string& note :
           io::WriteCalibration(io::ParseCalibrationFormat(a->to), outs, rig)) {
        std::cout << "  note: " << note << "\n";
      }
    }
    for (const auto& o : outs) std::cout << "wrote " << o.string() << "\n";
  });
}

FRINGE_REGISTER_COMMAND(55, AddConvertCalibCommand);

}  // namespace fringe::cli
