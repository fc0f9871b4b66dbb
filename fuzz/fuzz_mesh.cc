// Triangle-mesh readers (PLY faces, binary and ASCII STL, OBJ) behind io::ReadMesh, which
// `evaluate --truth` and `simulate mesh:FILE` hand user files to.
#include "fringe/io/mesh_io.h"
#include "fringe/util/error.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  for (const char* name : {"input.stl", "input.obj", "input.ply"}) {
    const auto path = fringe::fuzz::InputFile(data, size, name);
    try {
      fringe::io::ReadMesh(path);
    } catch (const fringe::Error&) {
    }
  }
  return 0;
}
