// fringe check PROJECT|VIEWCLOUD... --artefact FILE --out DIR: the VDI/VDE 2634-2 acceptance
// test (eval/check.h) of a certified artefact measured in one or more positions.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "fringe/cli/calibration_flags.h"
#include "fringe/cli/cli.h"
#include "fringe/eval/artefact.h"
#include "fringe/eval/check.h"
#include "fringe/io/json.h"
#include "fringe/pipeline/check.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::cli {

void AddCheckCommand(CLI::App& app) {
  struct Args {
    std::vector<std::string> inputs;
    std::string artefact, out;
    pipeline::CheckInputOptions input_options;
    bool json = false;
    eval::CheckOptions options;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "check",
      "VDI/VDE 2634-2 acceptance test: the certified artefact (--artefact, docs/formats.md) "
      "measured in one or more positions -> PF, PS, SD, F per position against the MPE, "
      "pass/fail, in OUT/check.json and OUT/check.html. Exit code 0 pass, 1 fail, 3 incomplete");
  sub->add_option("inputs", a->inputs,
                  "Measurements, one position each: point clouds (PLY), the output folder of "
                  "fringe scan (its views/NNN.ply), or a scan folder (its views reconstructed "
                  "with --calib or its rig.json)")
      ->required();
  sub->add_option("--artefact", a->artefact, "Artefact file (JSON, docs/formats.md)")->required();
  sub->add_option("--out", a->out, "Output folder: check.json, check.html")->required();
  AddCalibrationFlags(sub, &a->input_options, "for scan folders, their rig.json");
  sub->add_option("--band", a->options.vdi.inlier_band_mm,
                  "Half width of the band of points belonging to an artefact, mm")
      ->capture_default_str();
  sub->add_option("--discard", a->options.vdi.discard_fraction,
                  "Fraction of points that may be left out (<= 0.003)")
      ->capture_default_str();
  sub->add_option("--seed", a->options.vdi.seed, "RANSAC seed")->capture_default_str();
  sub->add_flag("--json", a->json, "Print check.json on stdout instead of the table");
  sub->callback([a] {
    a->options.Check();
    a->input_options.Check("check");  // conflicting calibration flags, before any reading
    std::vector<std::filesystem::path> inputs(a->inputs.begin(), a->inputs.end());
    util::OutputFolderOptions output;
    output.inputs = inputs;
    output.inputs.push_back(a->artefact);
    for (const auto& f : a->input_options.Files()) output.inputs.push_back(f);
    util::CheckOutputFolder(a->out, output);
    const eval::Artefact artefact = eval::ReadArtefact(a->artefact);
    const std::vector<eval::CheckInput> measurements =
        pipeline::ReadCheckInputs(inputs, a->input_options);
    const eval::CheckSummary s = eval::CheckArtefact(measurements, artefact, a->options);
    const nlohmann::json j = eval::ToJson(s, artefact, a->options);
    util::WriteFolderAtomically(a->out, output, [&](const std::filesystem::path& dir) {
      io::WriteJson(dir / "check.json", j);
      eval::CheckReport(s, artefact).Write(dir / "check.html");
    });
    if (a->json) {
      std::cout << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
    } else {
      std::cout << s.Table() << s.BriefReport() << "\nwrote " << a->out << "\n";
    }
    if (s.status == eval::CheckStatus::kFail) throw ExitWithCode(1);
    if (s.status == eval::CheckStatus::kIncomplete) throw ExitWithCode(3);
  });
}

FRINGE_REGISTER_COMMAND(105, AddCheckCommand);

}  // namespace fringe::cli
