// Uses the installed fringe: writes a mesh as binary STL and reads it back (io, geometry, util).
#include <cstdio>
#include <filesystem>

#include "fringe/geometry/triangle_mesh.h"
#include "fringe/io/mesh_io.h"

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  fringe::TriangleMesh octahedron;
  octahedron.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  octahedron.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                          {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  const std::filesystem::path path = std::filesystem::path(argv[1]) / "octahedron.stl";
  fringe::io::WriteMesh(path, octahedron);
  const fringe::TriangleMesh read = fringe::io::ReadMesh(path);
  std::printf("consumer ok: %zu triangles, %zu vertices\n", read.NumTriangles(),
              read.NumVertices());
  return read.NumTriangles() == 8 && read.NumVertices() == 6 ? 0 : 1;
}
