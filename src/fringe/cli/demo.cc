// fringe demo: the whole scanner on a simulated multi-view measurement of the built-in part with
// markers, plus the VDI/VDE 2634-2 artefacts, against the truth (pipeline/demo.h).
#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>

#include "fringe/cli/cli.h"
#include "fringe/pipeline/demo.h"

namespace fringe::cli {

void AddDemoCommand(CLI::App& app) {
  struct Args {
    std::string out = "fringe-demo";
    bool json = false;
    pipeline::DemoOptions options;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "demo",
      "The whole scanner on a simulated scan of the built-in part with markers (views around "
      "it) and the VDI/VDE 2634-2 artefacts: simulate, calibrate, reconstruct, register, fuse, "
      "mesh, report, evaluate against the truth");
  sub->add_option("--out", a->out, "Output folder (replaced)")->capture_default_str();
  sub->add_option("--views", a->options.views, "Sensor poses around the part")
      ->capture_default_str();
  sub->add_option("--rig-scale", a->options.rig_scale,
                  "Camera/projector resolution relative to 1280x1024 (1: full size; the default "
                  "half size keeps the demo short, see README)")
      ->capture_default_str();
  sub->add_option("--poisson-depth", a->options.scan.mesh.poisson_depth,
                  "Poisson octree depth of the mesh (0: from the point spacing and "
                  "--mesh-resolution)")
      ->capture_default_str();
  sub->add_option("--mesh-resolution", a->options.scan.mesh.resolution_mm,
                  "Wanted mesh resolution, mm (0: as fine as the points allow)")
      ->capture_default_str();
  sub->add_option("--poisson-pieces", a->options.scan.mesh.poisson_pieces,
                  "Poisson in two pieces side by side, joined on a grid plane: 0 automatic "
                  "(surfaces of 200,000 finest cells and more), 1 never, 2 always")
      ->check(CLI::Range(0, 2))
      ->capture_default_str();
  sub->add_option("--tolerance", a->options.scan.tolerance_mm,
                  "The report's deviation colours span +-this many mm (a tolerance band); "
                  "default: +-the 95th percentile of |deviation|")
      ->check(CLI::PositiveNumber);
  sub->add_option("--seed", a->options.seed, "Random seed")->capture_default_str();
  sub->add_option("--calibration-images", a->options.calibration_images,
                  "Board poses for calibration")
      ->capture_default_str();
  sub->add_option("--scheme", a->options.scheme, "Pattern scheme preset")->capture_default_str();
  sub->add_flag("--true-calibration", a->options.use_true_calibration,
                "Measure with the true rig instead of the estimated calibration");
  sub->add_flag(
      "--no-projector-columns", [a](int64_t) { a->options.scan.fit_projector_columns = false; },
      "Do not fit the projector's columns to the scan (the estimated calibration has no "
      "projector) nor drop the points off them");
  sub->add_flag("--json", a->json, "Print the figures as one JSON object");
  sub->callback([a] {
    const pipeline::DemoSummary s = pipeline::RunDemo(a->options, a->out);
    if (a->json) {
      std::cout << ToJson(s).dump(2) << "\n";
    } else {
      std::cout << s.Report() << "written to " << a->out << "/ (the scan's report: " << a->out
                << "/scan/report.html)\n";
    }
  });
}
FRINGE_REGISTER_COMMAND(10, AddDemoCommand);

}  // namespace fringe::cli
