// PLY reader (ASCII / binary / organized) and the `info` description built on it.
#include "fringe/io/ply.h"
#include "fringe/util/error.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = fringe::fuzz::InputFile(data, size, "input.ply");
  try {
    fringe::io::ReadPly(path);
  } catch (const fringe::Error&) {
  }
  try {
    fringe::io::ReadOrganizedPly(path);
  } catch (const fringe::Error&) {
  }
  return 0;
}
