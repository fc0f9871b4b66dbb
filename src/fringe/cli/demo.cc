// fringe demo: a simulated measurement of the built-in part and the VDI/VDE 2634-2 artefacts
// with the reference rig, end to end (pipeline/demo.h).
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
      "Simulated scan of the built-in part and the VDI/VDE 2634-2 artefacts: simulate, "
      "calibrate, reconstruct, evaluate against the truth");
  sub->add_option("--out", a->out, "Output folder (replaced)")->capture_default_str();
  sub->add_option("--seed", a->options.seed, "Random seed")->capture_default_str();
  sub->add_option("--calibration-images", a->options.calibration_images,
                  "Board poses for calibration")
      ->capture_default_str();
  sub->add_option("--scheme", a->options.scheme, "Pattern scheme preset")->capture_default_str();
  sub->add_flag("--true-calibration", a->options.use_true_calibration,
                "Measure with the true rig instead of the estimated calibration");
  sub->add_flag("--json", a->json, "Print the figures as one JSON object");
  sub->callback([a] {
    const pipeline::DemoSummary s = pipeline::RunDemo(a->options, a->out);
    if (a->json) {
      std::cout << s.ToJson().dump(2) << "\n";
    } else {
      std::cout << s.Report() << "written to " << a->out << "/\n";
    }
  });
}
FRINGE_REGISTER_COMMAND(10, AddDemoCommand);

}  // namespace fringe::cli
