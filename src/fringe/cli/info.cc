// fringe info PATH...: what is in a PLY, a calibration file or a scan folder.
#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>

#include "fringe/cli/cli.h"
#include "fringe/scan/describe.h"

namespace fringe::cli {

void AddInfoCommand(CLI::App& app) {
  auto paths = std::make_shared<std::vector<std::string>>();
  CLI::App* sub = app.add_subcommand(
      "info", "Print what is in a PLY file, a calibration (rig JSON) or a scan folder");
  sub->add_option("paths", *paths, "Files or folders")->required();
  sub->callback([paths] {
    for (const auto& p : *paths) std::cout << scan::DescribePath(p);
  });
}

FRINGE_REGISTER_COMMAND(110, AddInfoCommand);

}  // namespace fringe::cli
