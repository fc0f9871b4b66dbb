// fringe refine: the rig refined from a scan's own data (pipeline/refine.h).
#include <CLI/CLI.hpp>
#include <iostream>
#include <map>
#include <memory>

#include "fringe/cli/calibration_flags.h"
#include "fringe/cli/cli.h"
#include "fringe/pipeline/refine.h"
#include "fringe/util/error.h"

namespace fringe::cli {

void AddRefineCommand(CLI::App& app) {
  struct Args {
    std::string project, out;
    std::string scale = "auto";
    bool json = false;
    pipeline::RefineOptions options;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "refine",
      "Refine the rig from a stereo scan's own data: a bundle over the views' phase points (right "
      "camera phase, calibrated projector columns) and markers seen by both cameras, refining "
      "the right camera's pose (the projector's translation with --scale baseline) and with "
      "--intrinsics the cameras' focal lengths and k1 k2; writes RIG only when the data "
      "determine the result");
  sub->add_option("project", a->project, "Scan folder (stereo views, rig.json or --calib)")
      ->required();
  sub->add_option("--out", a->out, "Refined rig JSON (its summary inside as \"refinement\")")
      ->required();
  AddCalibrationFlags(sub, &a->options, "the scan folder's rig.json");
  sub->add_flag("--intrinsics", a->options.rig.intrinsics,
                "Also refine fx fy k1 k2 of both cameras");
  sub->add_option("--artefact", a->options.artefact,
                  "Artefact file (JSON, docs/formats.md) whose sphere is in the scan: its "
                  "certified diameter constrains the sphere's shape, which frees the depth bend "
                  "(right camera + projector yaw) and holds the scale");
  sub->add_option("--scale", a->scale,
                  "What holds the metric scale: projector (its pose stays; the baseline is "
                  "refined), baseline (its length stays; the projector's translation is refined), "
                  "artefact (the --artefact sphere's diameter) or auto (artefact with --artefact, "
                  "else projector when the rig has a calibrated projector)")
      ->check(CLI::IsMember({"auto", "baseline", "projector", "artefact"}))
      ->capture_default_str();
  sub->add_option("--points-per-view", a->options.points_per_view,
                  "Phase points sampled per view (0: markers only)")
      ->capture_default_str();
  sub->add_flag("--json", a->json, "Print the summary as one JSON object");
  sub->callback([a] {
    a->options.rig.scale = a->scale == "projector"  ? calib::RefineScale::kProjector
                           : a->scale == "baseline" ? calib::RefineScale::kBaseline
                           : a->scale == "artefact" ? calib::RefineScale::kArtefact
                                                    : calib::RefineScale::kAuto;
    if (a->options.rig.scale == calib::RefineScale::kArtefact && a->options.artefact.empty()) {
      throw Error("refine: --scale artefact needs --artefact FILE");
    }
    const pipeline::RefineResult r = pipeline::RefineScanRig(a->project, a->out, a->options);
    if (a->json) {
      std::cout << ToJson(r.summary).dump(2) << "\n";
    } else {
      std::cout << r.summary.BriefReport() << "\n";
    }
    // Not refined: an error naming why, nothing written.
    if (!r.summary.ok()) {
      throw Error("refine: " + a->project + ": " + r.summary.refinement.message +
                  "; nothing was written to " + a->out);
    }
    if (!a->json) std::cout << "written to " << a->out << "\n";
  });
}
FRINGE_REGISTER_COMMAND(92, AddRefineCommand);

}  // namespace fringe::cli
