// fringe patterns: write a pattern scheme's projector images (8-bit PNG) and its manifest.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>

#include "fringe/cli/cli.h"
#include "fringe/cli/scheme_flags.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/util/files.h"

namespace fringe::cli {

void AddPatternsCommand(CLI::App& app) {
  struct Args {
    std::string scheme = "thesis-4+3+3";
    std::string out;
    double gamma = 1.0;
    phase::SchemeParameters parameters;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "patterns", "Write the projector images of a fringe pattern scheme plus its manifest.json");
  std::string own, tools;
  for (const auto& n : phase::SchemePresetNames()) own += (own.empty() ? "" : ", ") + n;
  for (const auto& n : phase::ToolPresetNames()) tools += (tools.empty() ? "" : ", ") + n;
  sub->add_option("--scheme", a->scheme,
                  "Preset (" + own + ", gray+N; other tools' codecs: " + tools +
                      "; docs/formats.md) or a manifest JSON file")
      ->capture_default_str();
  sub->add_option("--out", a->out,
                  "Output folder (replaced atomically; an existing folder only if fringe wrote it)")
      ->required();
  sub->add_option("--gamma", a->gamma, "Pre-compensate the patterns for this projector gamma")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  AddSchemeFlags(sub, &a->parameters);
  sub->callback([a] {
    util::OutputFolderOptions output;
    if (std::filesystem::exists(a->scheme)) output.inputs.push_back(a->scheme);
    util::CheckOutputFolder(a->out, output);
    const phase::PatternScheme scheme = phase::SchemeFromArgument(a->scheme, a->parameters);
    phase::WritePatternFolder(a->out, scheme, a->gamma);
    std::cout << "wrote " << scheme.NumImages() << " patterns (" << scheme.name << ", "
              << scheme.projector_width << "x" << scheme.projector_height << ", "
              << phase::DirectionName(scheme.direction) << ", gamma " << a->gamma
              << ") and manifest.json to " << a->out << "\n";
  });
}

FRINGE_REGISTER_COMMAND(30, AddPatternsCommand);

}  // namespace fringe::cli
