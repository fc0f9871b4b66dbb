// fringe patterns: write a pattern scheme's projector images (8-bit PNG) and its manifest.
#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>

#include "fringe/cli/cli.h"
#include "fringe/phase/pattern_scheme.h"

namespace fringe::cli {

void AddPatternsCommand(CLI::App& app) {
  struct Args {
    std::string scheme = "thesis-4+3+3";
    std::string out;
    int width = 1280;
    int height = 800;
    double gamma = 1.0;
    bool horizontal = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "patterns", "Write the projector images of a fringe pattern scheme plus its manifest.json");
  sub->add_option("--scheme", a->scheme,
                  "Preset (heterodyne-4x3, thesis-4+3+3, heterodyne-3x3, gray+4, slsdk-phasegray) "
                  "or a manifest JSON file")
      ->capture_default_str();
  sub->add_option("--out", a->out, "Output folder (replaced atomically)")->required();
  sub->add_option("--width", a->width, "Projector width in pixels (presets)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_option("--height", a->height, "Projector height in pixels (presets)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_option("--gamma", a->gamma, "Pre-compensate the patterns for this projector gamma")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_flag("--horizontal", a->horizontal,
                "Horizontal fringes (phase along projector rows; presets only)");
  sub->callback([a] {
    phase::PatternScheme scheme = phase::SchemeFromNameOrFile(a->scheme, a->width, a->height);
    if (a->horizontal) {
      // Re-derive the preset's periods for the vertical span.
      const auto rotated = phase::MakeScheme(a->scheme, a->height, a->width);
      scheme.direction = phase::FringeDirection::kHorizontal;
      scheme.phase_sets = rotated.phase_sets;
      scheme.gray_bits = rotated.gray_bits;
      scheme.Check();
    }
    phase::WritePatternFolder(a->out, scheme, a->gamma);
    std::cout << "wrote " << scheme.NumImages() << " patterns (" << scheme.name << ", "
              << scheme.projector_width << "x" << scheme.projector_height << ", "
              << phase::DirectionName(scheme.direction) << ", gamma " << a->gamma
              << ") and manifest.json to " << a->out << "\n";
  });
}

FRINGE_REGISTER_COMMAND(30, AddPatternsCommand);

}  // namespace fringe::cli
