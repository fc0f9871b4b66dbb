// PLY (Stanford polygon format) reading and writing.
//
// Reads ASCII, binary little- and big-endian PLY with any element layout: the vertex element's
// x y z, nx ny nz, red green blue (or r g b / diffuse_*), intensity, quality (or confidence),
// residual_px and grid_index are picked up; a face element's vertex_indices (or vertex_index) lists
// become triangles (polygons are fanned); all other elements and properties (e.g. the Stanford
// scans' range_grid) are parsed and skipped. Errors name the file and what was wrong (truncation,
// bad header, bad number, index out of range).
//
// Writes binary little-endian (default) or ASCII; positions and normals as float (about 6e-5 mm
// resolution at 1 m). Organized clouds keep their grid: the header carries
// "comment fringe_grid <width> <height>" and each valid vertex a "uint grid_index" property
// (= row * width + col); invalid grid slots are not written. See docs/formats.md.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/triangle_mesh.h"

namespace fringe::io {

struct PlyProperty {
  std::string name;
  std::string type;             // scalar type, or the item type of a list
  std::string list_count_type;  // empty for scalar properties
};

struct PlyElement {
  std::string name;
  size_t count = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  std::string format;  // "ascii", "binary_little_endian" or "binary_big_endian"
  std::vector<std::string> comments;
  std::vector<PlyElement> elements;
  int grid_width = 0;  // from "comment fringe_grid W H", 0 when absent
  int grid_height = 0;
};

// What a PLY file holds, element by element: the vertex attributes as a cloud and the face
// element's triangles. Code that wants a mesh uses ReadPlyMesh / io::ReadMesh (mesh_io.h).
struct PlyData {
  PlyHeader header;
  PointCloud cloud;
  std::vector<TriangleMesh::Triangle> triangles;
  std::vector<uint32_t> grid_index;  // per vertex, when the file has grid_index
};

enum class PlyFormat { kBinaryLittleEndian, kAscii };

PlyHeader ReadPlyHeader(const std::filesystem::path& path);
PlyData ReadPly(const std::filesystem::path& path);
// Reads a file written by WritePly(OrganizedPointCloud); throws when it has no grid.
OrganizedPointCloud ReadOrganizedPly(const std::filesystem::path& path);
// The file's vertices (with normals and colours when present) and triangles; validated
// (TriangleMesh::Check), possibly without triangles.
TriangleMesh ReadPlyMesh(const std::filesystem::path& path);

// Writes atomically (temporary name, then rename). Throws fringe::Error on failure.
void WritePly(const std::filesystem::path& path, const PointCloud& cloud,
              PlyFormat format = PlyFormat::kBinaryLittleEndian,
              const std::vector<std::string>& comments = {});
// Vertices (with normals and colours when the mesh has them) and a face element.
void WritePly(const std::filesystem::path& path, const TriangleMesh& mesh,
              PlyFormat format = PlyFormat::kBinaryLittleEndian,
              const std::vector<std::string>& comments = {});
void WritePly(const std::filesystem::path& path, const OrganizedPointCloud& grid,
              PlyFormat format = PlyFormat::kBinaryLittleEndian,
              const std::vector<std::string>& comments = {});

}  // namespace fringe::io
