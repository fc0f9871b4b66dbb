// Reading and writing TriangleMesh files, chosen by extension (case-insensitive):
//   .ply  any PLY io::ReadPly reads (polygons fanned; vertex normals and colours kept);
//         written binary little-endian with normals and colours when the mesh has them.
//   .stl  binary or ASCII STL; vertices that are bit-identical are merged on reading, so the
//         mesh is connected (STL stores every triangle's corners separately). Written binary
//         (float positions, facet normals from the triangle order; no vertex attributes).
//   .obj  Wavefront OBJ `v` and `f` lines (texture / normal indices ignored, polygons fanned,
//         negative indices relative); written with `v` and `f` lines (and `vn` for normals).
// Readers throw fringe::Error naming the file for unreadable, truncated, empty or inconsistent
// meshes (index out of range, non-finite vertex); every count read from a file is checked
// against the file's size before anything is allocated. Writers write atomically (temporary
// name, then rename), positions as float (about 6e-5 mm resolution at 1 m) except OBJ (text,
// 9 significant digits).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "fringe/geometry/triangle_mesh.h"

namespace fringe::io {

// The mesh in a .ply, .stl or .obj file; throws when it has no triangles.
TriangleMesh ReadMesh(const std::filesystem::path& path);
// Writes .ply, .stl or .obj by extension; `comments` go into PLY headers (one line each) and the
// STL header (first 80 bytes). Throws fringe::Error for another extension or an invalid mesh.
void WriteMesh(const std::filesystem::path& path, const TriangleMesh& mesh,
               const std::vector<std::string>& comments = {});

TriangleMesh ReadStl(const std::filesystem::path& path);
void WriteStl(const std::filesystem::path& path, const TriangleMesh& mesh,
              const std::string& header = "");
TriangleMesh ReadObj(const std::filesystem::path& path);
void WriteObj(const std::filesystem::path& path, const TriangleMesh& mesh);

}  // namespace fringe::io
