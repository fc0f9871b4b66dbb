#include "fringe/cli/cli.h"
#include "fringe/util/memory.h"

int main(int argc, char** argv) {
  fringe::util::UseTransparentHugePages(argv);
  return fringe::cli::Main(argc, argv);
}
