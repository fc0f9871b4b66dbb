// The `fringe` command line: one subcommand per file, each a thin parser over a library function.
//
// Exit codes: 0 success, 1 error (bad input, failed step: the message names the file and the
// problem), 2 usage error (unknown subcommand or flag, bad flag value).
#pragma once

namespace CLI {
class App;
}

namespace fringe::cli {

int Main(int argc, char** argv);

// Subcommand registration, one per file (cli/<name>.cc).
void AddInfoCommand(CLI::App& app);
void AddDemoCommand(CLI::App& app);

}  // namespace fringe::cli
