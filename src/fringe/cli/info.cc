// fringe info PATH...: what is in a PLY, a calibration file or a scan folder.
// fringe info PROJECT --init: writes the scan.json inferred for a folder of views another tool
// wrote (scan::InferManifest), after checking the folder against it.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>

#include "fringe/cli/cli.h"
#include "fringe/scan/describe.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/util/error.h"

namespace fringe::cli {

void AddInfoCommand(CLI::App& app) {
  auto paths = std::make_shared<std::vector<std::string>>();
  auto init = std::make_shared<bool>(false);
  CLI::App* sub = app.add_subcommand(
      "info", "Print what is in a PLY file, a calibration (rig JSON) or a scan folder");
  sub->add_option("paths", *paths, "Files or folders")->required();
  sub->add_flag("--init", *init,
                "For a folder of views without scan.json: write the inferred scan.json");
  sub->callback([paths, init] {
    for (const auto& p : *paths) {
      if (*init) {
        const std::filesystem::path root(p);
        (void)scan::WriteInferredManifest(root);
        std::cout << "wrote " << scan::ScanLayout{root}.Manifest().string() << "\n";
      }
      std::cout << scan::DescribePath(p);
    }
  });
}

FRINGE_REGISTER_COMMAND(110, AddInfoCommand);

}  // namespace fringe::cli
