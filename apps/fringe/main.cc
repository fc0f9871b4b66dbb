#include <cstring>
#include <string>

#include "fringe/cli/cli.h"
#include "fringe/util/memory.h"

namespace {

// Huge pages pay for the commands that hold images and clouds (a view touches ~150 MB, each 4 KiB
// page costing a fault); the re-execution that enables them costs a second load of the ~330
// shared libraries behind OpenCV, Open3D and the rest (~0.3-0.5 CPU-s), which the commands that
// read a file header or write a few patterns never recoup, nor does printing help.
bool WorthHugePages(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0 ||
        std::strcmp(argv[i], "--version") == 0) {
      return false;
    }
  }
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--threads") == 0) {
      ++i;  // the one global option with a value
      continue;
    }
    if (argv[i][0] == '-') continue;  // a global flag before the command
    const std::string command = argv[i];
    return command != "info" && command != "convert-calib" && command != "patterns" &&
           command != "devices";
  }
  return false;  // no command: usage
}

}  // namespace

int main(int argc, char** argv) {
  if (WorthHugePages(argc, argv)) fringe::util::UseTransparentHugePages(argv);
  return fringe::cli::Main(argc, argv);
}
