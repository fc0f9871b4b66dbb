// fringe simulate SCENE --out DIR: a simulated scan folder (fringe images of every view,
// calibration board images, ground truth) from the virtual scanner (docs/scan-folder.md).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>

#include "fringe/cli/cli.h"
#include "fringe/io/calibration_io.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/sim/scan.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::cli {

void AddSimulateCommand(CLI::App& app) {
  struct Args {
    std::string scene;
    std::string out;
    std::string rig;
    double rig_scale = 1.0;
    sim::ScanOptions options;
    std::string scheme = "heterodyne-4x3";
    double precompensate_gamma = 1.0;  // applied to the scheme when given
    bool no_noise = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "simulate", "Render a simulated scan folder (fringe + calibration images, ground truth)");
  sub->add_option("scene", a->scene,
                  "demo | board | sphere | ballbar | plane | plate | vdi | mesh:FILE.ply|.obj|.stl")
      ->required();
  sub->add_option("--out", a->out, "Output folder (replaced atomically)")->required();
  sub->add_option("--views", a->options.views, "Number of fringe views")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--seed", a->options.seed, "Seed (markers, poses, noise)")->capture_default_str();
  sub->add_option("--rig", a->rig, "Rig JSON (default: the reference rig)");
  sub->add_option("--rig-scale", a->rig_scale,
                  "Scale the rig's resolution and focal lengths (e.g. 0.5 for a quick scan)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_option("--scheme", a->scheme, "Pattern scheme preset or manifest file")
      ->capture_default_str();
  // Sets the scheme's gamma_precompensation (the one statement of it, written to scheme.json);
  // without it a manifest keeps its own value and a preset is not pre-compensated.
  CLI::Option* gamma_option =
      sub->add_option("--precompensate-gamma", a->precompensate_gamma,
                      "Pre-compensate the patterns for this projector gamma (1 = none; default: "
                      "the manifest's value, none for a preset)")
          ->check(CLI::Range(1e-3, 10.0));
  sub->add_option("--calibration-images", a->options.calibration_images,
                  "Board poses (one image per camera each)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_flag("--turntable", a->options.orbit.turntable,
                "The part turns on a turntable instead of the sensor moving");
  sub->add_option("--supersampling", a->options.render.sensor.supersampling,
                  "n x n samples per pixel")
      ->capture_default_str()
      ->check(CLI::Range(1, 16));
  sub->add_option("--bit-depth", a->options.render.sensor.bit_depth, "8 or 12")
      ->capture_default_str()
      ->check(CLI::IsMember({8, 12}));
  sub->add_option("--gamma", a->options.render.projector.gamma, "Projector gamma")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_option("--read-noise", a->options.render.sensor.read_noise_dn, "Read noise sigma in DN")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_flag("--no-noise", a->no_noise, "Noise-free images");
  sub->add_option("--cameras", a->options.cameras,
                  "2: stereo views; 1: camera + projector views (left/ only, calibration/ as "
                  "board pose folders with both fringe directions)")
      ->capture_default_str()
      ->check(CLI::IsMember({1, 2}));
  sub->add_flag("--both-directions", a->options.both_directions,
                "With --cameras 1: horizontal fringes too (views hold left/vertical/ and "
                "left/horizontal/; scheme_horizontal.json)");
  sub->add_option("--exposures", a->options.exposures,
                  "Exposure factors of every stack, comma separated (e.g. 1,0.3): more than one "
                  "writes exposure folders e0/, e1/, ...")
      ->delimiter(',')
      ->capture_default_str();
  sub->add_flag("!--no-truth-maps", a->options.truth_maps,
                "Skip the per-view truth maps (they take ~30 MB per view and camera)");
  sub->callback([a, gamma_option] {
    util::OutputFolderOptions output;
    output.inputs = {a->rig};
    if (std::filesystem::exists(a->scheme)) output.inputs.push_back(a->scheme);
    if (a->scene.rfind("mesh:", 0) == 0) output.inputs.push_back(a->scene.substr(5));
    util::CheckOutputFolder(a->out, output);
    StereoRig rig = a->rig.empty() ? StereoRig::Reference() : io::ReadRig(a->rig);
    if (a->rig_scale != 1.0) {
      // The scaled images are allocated per view: bound them before rendering anything.
      for (const CameraModel* c : {&rig.left, &rig.right}) {
        const double w = c->width * a->rig_scale, h = c->height * a->rig_scale;
        if (w > util::kMaxImageSidePx || h > util::kMaxImageSidePx ||
            w * h > static_cast<double>(util::kMaxImagePixels) || w < 8 || h < 8) {
          throw Error(util::StrCat("--rig-scale ", a->rig_scale, ": camera images of ", w, " x ", h,
                                   " pixels (sides must be in [8, ", util::kMaxImageSidePx,
                                   "], at most ", util::kMaxImagePixels, " pixels)"));
        }
      }
      rig = sim::ScaledRig(rig, a->rig_scale);
    }
    sim::ScanOptions options = a->options;
    options.scene = a->scene;
    if (options.both_directions && options.cameras != 1) {
      throw CLI::ValidationError("--both-directions",
                                 "needs --cameras 1 (stereo matching uses vertical fringes only)");
    }
    if (options.views > 0 && rig.projector) {
      options.scheme =
          phase::SchemeFromNameOrFile(a->scheme, rig.projector->width, rig.projector->height);
      if (gamma_option->count() > 0) options.scheme->gamma_precompensation = a->precompensate_gamma;
    }
    if (a->no_noise) {
      options.render.sensor.noise = false;
      options.board.sensor.noise = false;
    }
    options.board.sensor.bit_depth = options.render.sensor.bit_depth;
    options.board.sensor.read_noise_dn = options.render.sensor.read_noise_dn;
    const sim::ScanSummary summary = sim::SimulateScan(rig, options, a->out);
    std::cout << summary.BriefReport() << " -> " << a->out << "\n";
  });
}

FRINGE_REGISTER_COMMAND(20, AddSimulateCommand);

}  // namespace fringe::cli
