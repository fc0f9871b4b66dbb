#include "fringe/cli/cli.h"

int main(int argc, char** argv) { return fringe::cli::Main(argc, argv); }
