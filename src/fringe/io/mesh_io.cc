#include "fringe/io/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "fringe/io/ply.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace {

using util::StrCat;

std::string LowerExtension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

// Index of a vertex, merging bit-identical positions (STL repeats shared corners).
class VertexWelder {
 public:
  explicit VertexWelder(TriangleMesh* mesh) : mesh_(mesh) {}
  int32_t Add(const float xyz[3]) {
    const std::array<float, 3> key = {xyz[0], xyz[1], xyz[2]};
    const auto [it, inserted] = index_.emplace(key, static_cast<int32_t>(mesh_->vertices.size()));
    if (inserted) mesh_->vertices.emplace_back(xyz[0], xyz[1], xyz[2]);
    return it->second;
  }

 private:
  TriangleMesh* mesh_;
  std::map<std::array<float, 3>, int32_t> index_;
};

constexpr size_t kStlHeaderBytes = 80;
constexpr size_t kStlTriangleBytes = 50;  // normal, 3 vertices (float x 12), uint16 attribute

TriangleMesh ReadBinaryStl(const std::string& data, uint32_t count) {
  TriangleMesh m;
  VertexWelder weld(&m);
  m.triangles.reserve(count);
  for (uint32_t i = 0; i < count; ++i) {
    const char* rec = data.data() + kStlHeaderBytes + 4 + kStlTriangleBytes * i + 12;
    TriangleMesh::Triangle t;
    for (int k = 0; k < 3; ++k) {
      float xyz[3];
      std::memcpy(xyz, rec + 12 * k, 12);
      t[k] = weld.Add(xyz);
    }
    m.triangles.push_back(t);
  }
  return m;
}

TriangleMesh ReadAsciiStl(const std::string& data, const std::string& file) {
  TriangleMesh m;
  VertexWelder weld(&m);
  std::istringstream in(data);
  std::string word;
  std::vector<int32_t> corners;
  while (in >> word) {
    if (word == "vertex") {
      double p[3];
      if (!(in >> p[0] >> p[1] >> p[2])) {
        throw Error(StrCat(file, ": bad ASCII STL vertex in facet ", m.triangles.size()));
      }
      // Positions are welded at float precision, as in binary STL.
      const float xyz[3] = {static_cast<float>(p[0]), static_cast<float>(p[1]),
                            static_cast<float>(p[2])};
      corners.push_back(weld.Add(xyz));
    } else if (word == "endfacet") {
      if (corners.size() != 3) {
        throw Error(StrCat(file, ": ASCII STL facet ", m.triangles.size(), " has ", corners.size(),
                           " vertices (expected 3)"));
      }
      m.triangles.push_back({corners[0], corners[1], corners[2]});
      corners.clear();
    }
  }
  return m;
}

// OBJ face item "i", "i/t", "i//n" or "i/t/n": the vertex index as 0-based, or throws.
int32_t ObjVertexIndex(const std::string& item, size_t num_vertices, const std::string& where) {
  const std::string head = item.substr(0, item.find('/'));
  errno = 0;
  char* end = nullptr;
  const long i = std::strtol(head.c_str(), &end, 10);
  if (head.empty() || *end != '\0' || errno != 0 || i == 0) {
    throw Error(StrCat(where, ": bad face index '", item, "'"));
  }
  const long n = static_cast<long>(num_vertices);
  const long idx = i > 0 ? i - 1 : n + i;
  if (idx < 0 || idx >= n) {
    throw Error(StrCat(where, ": face index ", i, " outside the ", n, " vertices read so far"));
  }
  return static_cast<int32_t>(idx);
}

}  // namespace

TriangleMesh ReadStl(const std::filesystem::path& path) {
  const std::string file = path.string();
  const std::string data = util::ReadTextFile(path);
  // Binary when the triangle count in bytes 80-83 accounts for the file size exactly (ASCII
  // files start with "solid", but so do some binary headers).
  if (data.size() >= kStlHeaderBytes + 4) {
    uint32_t count = 0;
    std::memcpy(&count, data.data() + kStlHeaderBytes, 4);
    if (data.size() == kStlHeaderBytes + 4 + kStlTriangleBytes * static_cast<uint64_t>(count)) {
      return ReadBinaryStl(data, count);
    }
  }
  if (data.compare(0, 5, "solid") != 0) {
    throw Error(StrCat(file,
                       ": not an STL file (neither a binary STL whose triangle count matches the "
                       "file size nor ASCII STL starting with 'solid')"));
  }
  return ReadAsciiStl(data, file);
}

TriangleMesh ReadObj(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::istringstream in(util::ReadTextFile(path));
  TriangleMesh m;
  std::string line;
  int line_no = 0;
  std::vector<int32_t> poly;
  while (std::getline(in, line)) {
    ++line_no;
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "v") {
      Eigen::Vector3d p;
      if (!(ls >> p.x() >> p.y() >> p.z())) {
        throw Error(StrCat(file, ":", line_no, ": bad vertex line"));
      }
      m.vertices.push_back(p);
    } else if (tag == "f") {
      poly.clear();
      std::string item;
      const std::string where = StrCat(file, ":", line_no);
      while (ls >> item) poly.push_back(ObjVertexIndex(item, m.vertices.size(), where));
      if (poly.size() < 3) throw Error(StrCat(where, ": face with fewer than 3 vertices"));
      for (size_t k = 2; k < poly.size(); ++k)
        m.triangles.push_back({poly[0], poly[k - 1], poly[k]});
    }
  }
  return m;
}

TriangleMesh ReadMesh(const std::filesystem::path& path) {
  util::RequireFile(path, "mesh");
  const std::string ext = LowerExtension(path);
  TriangleMesh m;
  if (ext == ".ply") {
    m = ReadPlyMesh(path);
  } else if (ext == ".obj") {
    m = ReadObj(path);
  } else if (ext == ".stl") {
    m = ReadStl(path);
  } else {
    throw Error(StrCat(path.string(), ": unknown mesh extension '", ext,
                       "' (expected .ply, .obj or .stl)"));
  }
  m.Check(path.string());
  if (m.triangles.empty()) throw Error(StrCat(path.string(), ": mesh has no triangles"));
  return m;
}

void WriteStl(const std::filesystem::path& path, const TriangleMesh& mesh,
              const std::string& header) {
  mesh.Check(path.string());
  if (mesh.triangles.size() > std::numeric_limits<uint32_t>::max()) {
    throw Error(StrCat(path.string(), ": ", mesh.triangles.size(),
                       " triangles do not fit binary STL's 32-bit count"));
  }
  util::WriteAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw Error(StrCat(path.string(), ": cannot open for writing"));
    // A header starting with "solid" would make some readers take the file for ASCII STL.
    std::string head = "fringe binary STL, mm" + (header.empty() ? "" : "; " + header);
    head.resize(kStlHeaderBytes, ' ');
    out.write(head.data(), static_cast<std::streamsize>(kStlHeaderBytes));
    const uint32_t count = static_cast<uint32_t>(mesh.triangles.size());
    out.write(reinterpret_cast<const char*>(&count), 4);
    std::vector<char> buf;
    buf.reserve(kStlTriangleBytes * std::min<size_t>(count, 1 << 16));
    auto put_vec = [&](const Eigen::Vector3d& v) {
      const float f[3] = {static_cast<float>(v.x()), static_cast<float>(v.y()),
                          static_cast<float>(v.z())};
      const char* p = reinterpret_cast<const char*>(f);
      buf.insert(buf.end(), p, p + 12);
    };
    for (size_t i = 0; i < mesh.triangles.size(); ++i) {
      put_vec(mesh.TriangleNormal(i));
      for (int32_t k : mesh.triangles[i]) put_vec(mesh.vertices[k]);
      buf.push_back(0), buf.push_back(0);  // attribute byte count
      if (buf.size() >= (1 << 20)) {
        out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
        buf.clear();
      }
    }
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
    util::CloseOutput(out, path);
  });
}

void WriteObj(const std::filesystem::path& path, const TriangleMesh& mesh) {
  mesh.Check(path.string());
  util::WriteAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp);
    if (!out) throw Error(StrCat(path.string(), ": cannot open for writing"));
    out.precision(9);
    out << "# written by fringe; units: millimetres\n";
    for (const auto& v : mesh.vertices)
      out << "v " << v.x() << " " << v.y() << " " << v.z() << "\n";
    for (const auto& n : mesh.normals)
      out << "vn " << n.x() << " " << n.y() << " " << n.z() << "\n";
    for (const auto& t : mesh.triangles) {
      out << "f";
      for (int32_t k : t) {
        out << " " << k + 1;
        if (mesh.has_normals()) out << "//" << k + 1;
      }
      out << "\n";
    }
    util::CloseOutput(out, path);
  });
}

void WriteMesh(const std::filesystem::path& path, const TriangleMesh& mesh,
               const std::vector<std::string>& comments) {
  const std::string ext = LowerExtension(path);
  if (ext == ".ply") {
    WritePly(path, mesh, PlyFormat::kBinaryLittleEndian, comments);
  } else if (ext == ".stl") {
    std::string header;
    for (const auto& c : comments) header += (header.empty() ? "" : "; ") + c;
    WriteStl(path, mesh, header);
  } else if (ext == ".obj") {
    WriteObj(path, mesh);
  } else {
    throw Error(StrCat(path.string(), ": unknown mesh extension '", ext,
                       "' (expected .ply, .obj or .stl)"));
  }
}

}  // namespace fringe::io
