// fringe decode: one camera's fringe image stack -> absolute phase, modulation, mask.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>

#include "fringe/cli/cli.h"
#include "fringe/cli/scheme_flags.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/gamma.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/stack_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::cli {

void AddDecodeCommand(CLI::App& app) {
  struct Args {
    std::string stack;
    std::string scheme;
    std::string out;
    phase::DecodeOptions options;
    bool estimate_gamma = false;
    phase::SchemeParameters parameters;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "decode",
      "Decode one camera's fringe images to absolute phase (projector pixels), modulation and "
      "mask (32-bit float TIFF + PNG previews + summary.json)");
  sub->add_option("stack", a->stack,
                  "Folder with the images named in the manifest, or with exposure folders e0/, "
                  "e1/, ... of such images (combined per pixel: the highest unsaturated "
                  "modulation wins)")
      ->required();
  sub->add_option("--scheme", a->scheme,
                  "Scheme manifest (manifest.json) or preset name (with the scheme flags below)")
      ->required();
  AddSchemeFlags(sub, &a->parameters);
  sub->add_option("--out", a->out, "Output folder (replaced atomically)")->required();
  sub->add_option("--noise-sigma", a->options.noise_sigma_dn,
                  "Camera noise in DN (sets the automatic modulation threshold); 0 estimates it "
                  "from the images' least-squares residual")
      ->capture_default_str();
  sub->add_option("--min-modulation", a->options.min_modulation_dn,
                  "Modulation threshold in DN (<= 0: from the noise analysis)")
      ->capture_default_str();
  sub->add_option("--full-scale", a->options.full_scale_dn,
                  "Camera full scale in DN, e.g. 4095 for 12-bit data in 16-bit files (<= 0: from "
                  "the image depth)")
      ->capture_default_str();
  sub->add_option("--gamma", a->options.projector_gamma,
                  "Measured projector gamma (0: unknown). The decoder corrects only what the "
                  "scheme's gamma_precompensation did not: gamma / gamma_precompensation")
      ->capture_default_str();
  sub->add_flag("--estimate-gamma", a->estimate_gamma,
                "Also estimate the projector gamma (stack of a smooth surface, patterns not "
                "pre-compensated) and print it");
  sub->callback([a] {
    // The output folder must not hold the stack or the manifest (replacing it would delete
    // them); checked before the work, as is everything about the output location.
    util::OutputFolderOptions output;
    output.inputs = {a->stack};
    if (std::filesystem::exists(a->scheme)) output.inputs.push_back(a->scheme);
    util::CheckOutputFolder(a->out, output);
    const phase::PatternScheme scheme = phase::SchemeFromArgument(a->scheme, a->parameters);
    // One stack, or several exposures in e0/, e1/, ... (combined per pixel).
    const auto stacks = phase::ReadExposureStacks(a->stack, scheme);
    const auto& images = stacks.front();
    const phase::DecodeResult result = phase::DecodeExposures(scheme, stacks, a->options);
    std::cout << result.summary.BriefReport() << "\n";
    phase::WarnIfSchemeMismatch(result.summary, scheme.name, a->stack);
    if (result.summary.status != phase::DecodeStatus::kSuccess) {
      throw Error(util::StrCat(a->stack, ": decoding failed: ", result.summary.message,
                               " (nothing written)"));
    }
    phase::WriteDecodeFolder(a->out, result);
    if (a->estimate_gamma) {  // from the first exposure
      std::cout << phase::EstimateGamma(scheme, images).BriefReport() << "\n";
    }
  });
}

FRINGE_REGISTER_COMMAND(40, AddDecodeCommand);

}  // namespace fringe::cli
