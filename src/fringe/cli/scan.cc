// fringe scan: a scan folder to a measured model and a report (pipeline/scan.h).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "fringe/cli/calibration_flags.h"
#include "fringe/cli/cli.h"
#include "fringe/pipeline/scan.h"
#include "fringe/scan/scan_folder.h"

namespace fringe::cli {

void AddScanCommand(CLI::App& app) {
  struct Args {
    std::string project;
    std::string out;
    bool json = false;
    bool write_manifest = false;
    pipeline::ScanOptions options;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "scan",
      "The whole scanner: calibrate if needed, reconstruct every view of a scan folder, detect "
      "markers, register, fuse and mesh; writes the clouds, poses, marker map, fused cloud, "
      "mesh, summary.json and report.html (docs/scan-folder.md)");
  sub->add_option("project", a->project,
                  "Scan folder: scheme.json, views/NNN/{left,right}/ (left/ only for a camera + "
                  "projector scan, scan.json \"cameras\": 1), and rig.json or calibration/ "
                  "board images")
      ->required();
  sub->add_option("--out", a->out,
                  "Output folder (written atomically; an existing one is replaced only when "
                  "fringe wrote it)")
      ->required();
  AddCalibrationFlags(sub, &a->options, "the scan folder's rig.json, else its calibration/");
  sub->add_flag("--keep-going", a->options.keep_going,
                "Leave out views that fail and finish with the others (exit code 3)");
  sub->add_option("--views-in-flight", a->options.views_in_flight,
                  "Views reconstructed at once (bounds memory)")
      ->capture_default_str();
  sub->add_option("--memory-limit", a->options.memory_limit_gib,
                  "Memory the scan may use, GiB (default: half the machine's memory): fewer views "
                  "in flight, and fusion in spatial tiles streamed from OUT/views/ when the views "
                  "do not fit at once; a limit below one view is an error")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--fusion-tile", a->options.fusion_tile_mm,
                  "Fusion tile edge, mm (default: chosen from --memory-limit; one tile when the "
                  "views fit)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--noise-sigma", a->options.reconstruction.decode.noise_sigma_dn,
                  "Camera noise in DN (sets the decoder's modulation threshold)")
      ->capture_default_str();
  sub->add_option(
         "--poisson-depth", a->options.mesh.poisson_depth,
         "Poisson octree depth of the mesh (0: from the point spacing and --mesh-resolution; "
         "10: ~0.3 mm cells on 300 mm)")
      ->capture_default_str();
  sub->add_option("--mesh-resolution", a->options.mesh.resolution_mm,
                  "Wanted mesh resolution, mm: the automatic Poisson depth's finest cell is "
                  "this (or 2 point spacings if coarser; 0: as fine as the points allow)")
      ->capture_default_str();
  sub->add_option("--poisson-pieces", a->options.mesh.poisson_pieces,
                  "Poisson in two pieces side by side, joined on a grid plane: 0 automatic "
                  "(surfaces of 200,000 finest cells and more), 1 never, 2 always")
      ->check(CLI::Range(0, 2))
      ->capture_default_str();
  sub->add_flag(
      "--no-markers", [a](int64_t) { a->options.registration.use_markers = false; },
      "Register without markers (marker-free coarse alignment + ICP)");
  sub->add_flag(
      "--no-report", [a](int64_t) { a->options.write_report = false; }, "Do not write report.html");
  sub->add_option("--tolerance", a->options.tolerance_mm,
                  "The report's deviation colours span +-this many mm (a tolerance band); "
                  "default: +-the 95th percentile of |deviation|")
      ->check(CLI::PositiveNumber);
  sub->add_flag(
      "--no-projector-columns", [a](int64_t) { a->options.fit_projector_columns = false; },
      "Stereo rig without a calibrated projector: do not fit the projector's columns to the "
      "scan nor drop the points off them (false matches at occlusions)");
  sub->add_flag("--write-manifest", a->write_manifest,
                "A folder of views without scan.json (another tool's capture): write the "
                "scan.json inferred from it into PROJECT before scanning (never overwrites one)");
  sub->add_flag("--refine", a->options.refine,
                "Stereo: refine the rig from this scan's own data before reconstructing (as "
                "fringe refine; used only when the data determine it)");
  sub->add_flag(
      "--refine-intrinsics", [a](int64_t) { a->options.refine_options.rig.intrinsics = true; },
      "With --refine: also the cameras' focal lengths and k1 k2");
  sub->add_option("--refine-artefact", a->options.refine_options.artefact,
                  "With --refine: an artefact file whose sphere is in the scan (as fringe refine "
                  "--artefact)");
  sub->add_flag("--json", a->json, "Print the summary as one JSON object");
  sub->add_flag("--resume", a->options.resume,
                "After an interrupted run of the same scan into the same --out (killed, a crash, "
                "a power cut): reuse the views it finished, when their images, the rig and these "
                "options are unchanged; the result is the one an uninterrupted run gives");
  sub->callback([a, sub] {
    // The options as given (every flag and its value, defaults included), less those that do
    // not change the views' results (--tolerance colours the report only): the key of the views'
    // checkpoints (ScanOptions::resume_key).
    std::istringstream config(sub->config_to_str(true, false));
    a->options.resume_key.clear();
    for (std::string line; std::getline(config, line);) {
      if (line.rfind("resume", 0) == 0 || line.rfind("json", 0) == 0 ||
          line.rfind("write-manifest", 0) == 0 || line.rfind("tolerance", 0) == 0) {
        continue;
      }
      a->options.resume_key += line + "\n";
    }
    if (a->write_manifest) {
      // With --json, stdout holds only the summary.
      std::ostream& out = a->json ? std::cerr : std::cout;
      const std::filesystem::path root(a->project);
      if (scan::ScanFolder::IsScanFolder(root)) {
        out << "note: " << scan::ScanLayout{root}.Manifest().string()
            << " exists: --write-manifest leaves it as it is\n";
      } else {
        for (const std::string& n : scan::WriteInferredManifest(root).notes) {
          out << "inferred: " << n << "\n";
        }
        out << "wrote " << scan::ScanLayout{root}.Manifest().string() << "\n";
      }
    }
    const pipeline::ScanSummary s = pipeline::RunScan(a->project, a->out, a->options);
    if (a->json) {
      std::cout << ToJson(s).dump(2) << "\n";
    } else {
      std::cout << s.BriefReport() << "\nwritten to " << a->out << "/\n";
    }
    if (s.partial()) throw ExitWithCode(3);
  });
}
FRINGE_REGISTER_COMMAND(90, AddScanCommand);

}  // namespace fringe::cli
