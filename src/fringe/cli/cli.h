// The `fringe` command line: one subcommand per file (cli/<name>.cc), each a thin parser over a
// library function, registered with FRINGE_REGISTER_COMMAND so that adding a subcommand touches
// no shared file.
//
// Exit codes: 0 success, 1 error (bad input, failed step: the message names the file and the
// problem), 2 usage error (unknown subcommand or flag, bad flag value), 3 partial success (the
// command finished without some of its inputs, e.g. `scan --keep-going` left a view out).
#pragma once

#include <stdexcept>

namespace CLI {
class App;
}

namespace fringe::cli {

// Thrown by a subcommand AFTER it wrote its results, to make the program exit with `code`
// (3: partial success) without an error message.
class ExitWithCode : public std::exception {
 public:
  explicit ExitWithCode(int code) : code_(code) {}
  int code() const { return code_; }
  const char* what() const noexcept override { return "exit with code"; }

 private:
  int code_;
};

int Main(int argc, char** argv);

using AddCommandFn = void (*)(CLI::App& app);

// Registers a subcommand; `order` sets its place in --help (the pipeline order:
// 10 demo, 20 simulate, 30 patterns, 40 decode, 50 calibrate, 60 reconstruct, 70 register,
// 80 fuse, 90 scan, 100 evaluate, 105 check, 110 info).
struct CommandRegistration {
  CommandRegistration(int order, AddCommandFn add);
};

}  // namespace fringe::cli

// In a subcommand's .cc file, at namespace scope inside fringe::cli:
//   void AddInfoCommand(CLI::App& app) { ... }
//   FRINGE_REGISTER_COMMAND(110, AddInfoCommand);
// The cli target is an OBJECT library so these static registrations are never dropped.
#define FRINGE_REGISTER_COMMAND(order, fn) \
  static const ::fringe::cli::CommandRegistration fn##_registration { order, fn }
