#include <tbb/global_control.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <new>
#include <utility>
#include <vector>

#include "fringe/cli/cli.h"
#include "fringe/util/error.h"
#include "fringe/util/log.h"

#ifndef FRINGE_VERSION
#define FRINGE_VERSION "unknown"
#endif

namespace fringe::cli {

namespace {

std::vector<std::pair<int, AddCommandFn>>& Registry() {
  static std::vector<std::pair<int, AddCommandFn>> registry;
  return registry;
}

bool HasSubcommand(const CLI::App& app, const std::string& name) {
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (sub->get_name() == name) return true;
  }
  return false;
}

}  // namespace

CommandRegistration::CommandRegistration(int order, AddCommandFn add) {
  Registry().emplace_back(order, add);
}

int Main(int argc, char** argv) {
  CLI::App app{"fringe: fringe-projection (phase-shifting structured-light) 3D measurement",
               "fringe"};
  app.set_version_flag("--version", std::string("fringe ") + FRINGE_VERSION);
  app.require_subcommand(1);
  bool quiet = false, verbose = false;
  app.add_flag("-q,--quiet", quiet, "Print only results and errors");
  app.add_flag("-v,--verbose", verbose, "Print details of every step");
  int threads = 0;
  app.add_option("--threads", threads, "Worker threads (0: all cores); results do not depend on it")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  // Lives until Main returns: every parallel loop of the command runs under the limit.
  std::unique_ptr<tbb::global_control> thread_limit;
  app.footer(
      "Run 'fringe <command> --help' for the options of a command.\n"
      "Exit codes: 0 success, 1 error or no result (the message names the file and the problem), "
      "2 usage error, 3 partial success (e.g. scan --keep-going).");

  auto commands = Registry();
  std::stable_sort(commands.begin(), commands.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [order, add] : commands) add(app);

  app.parse_complete_callback([&] {
    if (threads > 0) {
      thread_limit = std::make_unique<tbb::global_control>(
          tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
    }
    util::SetVerbosity(quiet     ? util::Verbosity::kQuiet
                       : verbose ? util::Verbosity::kVerbose
                                 : util::Verbosity::kNormal);
  });

  // CLI11 reports a misspelt subcommand as "a subcommand is required"; name it instead.
  if (argc > 1 && argv[1][0] != '-' && !HasSubcommand(app, argv[1])) {
    std::fprintf(stderr,
                 "fringe: usage error: unknown subcommand '%s'\nRun 'fringe --help' for usage.\n",
                 argv[1]);
    return 2;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "fringe: usage error: %s\nRun 'fringe --help' for usage.\n", e.what());
    return 2;
  } catch (const ExitWithCode& e) {
    return e.code();
  } catch (const fringe::Error& e) {
    std::fprintf(stderr, "fringe: error: %s\n", e.what());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "fringe: error: out of memory\n");
    return 1;
  } catch (const std::filesystem::filesystem_error& e) {
    // Name the user's path (the library's own message already does).
    std::fprintf(stderr, "fringe: error: %s: %s\n", e.path1().string().c_str(),
                 e.code().message().c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fringe: internal error: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace fringe::cli
