// fringe demo: the end-to-end demonstration on built-in data (README's first command).
//
// Until the virtual scanner lands (issue 3) this only exercises what exists: it writes the
// reference rig's calibration and describes it.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>

#include "fringe/cli/cli.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/describe.h"

namespace fringe::cli {

void AddDemoCommand(CLI::App& app) {
  auto out = std::make_shared<std::string>("fringe-demo");
  CLI::App* sub = app.add_subcommand("demo", "Simulated scan of the built-in part, end to end");
  sub->add_option("--out", *out, "Output folder")->capture_default_str();
  sub->callback([out] {
    std::filesystem::create_directories(*out);
    const auto rig_path = std::filesystem::path(*out) / "rig.json";
    io::WriteRig(rig_path, StereoRig::Reference());
    std::cout << io::DescribePath(rig_path);
  });
}

FRINGE_REGISTER_COMMAND(10, AddDemoCommand);

}  // namespace fringe::cli
