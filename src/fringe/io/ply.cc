#include "fringe/io/ply.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace {

using util::StrCat;

enum class Type { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64 };

bool ParseType(const std::string& s, Type* t) {
  static const std::pair<const char*, Type> kNames[] = {
      {"char", Type::kInt8},      {"int8", Type::kInt8},       {"uchar", Type::kUInt8},
      {"uint8", Type::kUInt8},    {"short", Type::kInt16},     {"int16", Type::kInt16},
      {"ushort", Type::kUInt16},  {"uint16", Type::kUInt16},   {"int", Type::kInt32},
      {"int32", Type::kInt32},    {"uint", Type::kUInt32},     {"uint32", Type::kUInt32},
      {"float", Type::kFloat32},  {"float32", Type::kFloat32}, {"double", Type::kFloat64},
      {"float64", Type::kFloat64}};
  for (const auto& [name, type] : kNames) {
    if (s == name) {
      *t = type;
      return true;
    }
  }
  return false;
}

size_t TypeSize(Type t) {
  switch (t) {
    case Type::kInt8:
    case Type::kUInt8:
      return 1;
    case Type::kInt16:
    case Type::kUInt16:
      return 2;
    case Type::kInt32:
    case Type::kUInt32:
    case Type::kFloat32:
      return 4;
    case Type::kFloat64:
      return 8;
  }
  return 0;
}

// Where the header ends and the parsed header; throws on a malformed header.
PlyHeader ParseHeader(const std::string& data, const std::string& file, size_t* body_offset) {
  PlyHeader h;
  if (data.compare(0, 3, "ply") != 0)
    throw Error(StrCat(file, ": not a PLY file (no 'ply' magic)"));
  size_t pos = 0;
  int line_no = 0;
  bool ended = false;
  while (pos < data.size()) {
    size_t eol = data.find('\n', pos);
    if (eol == std::string::npos) break;
    std::string line = data.substr(pos, eol - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = eol + 1;
    ++line_no;
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    if (line_no == 1) {
      if (key != "ply") throw Error(StrCat(file, ": not a PLY file (no 'ply' magic)"));
      continue;
    }
    if (key == "format") {
      std::string version;
      ls >> h.format >> version;
      if (h.format != "ascii" && h.format != "binary_little_endian" &&
          h.format != "binary_big_endian") {
        throw Error(StrCat(file, ": header line ", line_no, ": unknown format '", h.format, "'"));
      }
      if (version != "1.0") {
        throw Error(StrCat(file, ": header line ", line_no, ": PLY version '", version,
                           "' (only 1.0 exists)"));
      }
    } else if (key == "comment" || key == "obj_info") {
      std::string rest;
      std::getline(ls, rest);
      if (!rest.empty() && rest[0] == ' ') rest.erase(0, 1);
      h.comments.push_back(rest);
      std::istringstream cs(rest);
      std::string tag;
      cs >> tag;
      if (tag == "fringe_grid") {
        // Bounded before anything is sized from it: readers allocate width x height cells.
        long long w = 0, ht = 0;
        if (!(cs >> w >> ht) || w < 1 || ht < 1 || w > util::kMaxImageSidePx ||
            ht > util::kMaxImageSidePx || w * ht > util::kMaxImagePixels) {
          throw Error(StrCat(file, ": header line ", line_no,
                             ": malformed 'comment fringe_grid <width> <height>' (sides in [1, ",
                             util::kMaxImageSidePx, "], at most ", util::kMaxImagePixels,
                             " pixels)"));
        }
        h.grid_width = static_cast<int>(w);
        h.grid_height = static_cast<int>(ht);
      }
    } else if (key == "element") {
      PlyElement e;
      long long count = -1;
      std::string rest;
      if (!(ls >> e.name >> count) || e.name.empty() || count < 0 || (ls >> rest)) {
        throw Error(StrCat(file, ": header line ", line_no,
                           ": bad element declaration (expected 'element <name> <count>')"));
      }
      e.count = static_cast<size_t>(count);
      h.elements.push_back(e);
    } else if (key == "property") {
      if (h.elements.empty()) {
        throw Error(StrCat(file, ": header line ", line_no, ": property before any element"));
      }
      PlyProperty p;
      std::string type;
      ls >> type;
      Type t;
      if (type == "list") {
        ls >> p.list_count_type >> p.type >> p.name;
        if (!ParseType(p.list_count_type, &t) || !ParseType(p.type, &t)) {
          throw Error(StrCat(file, ": header line ", line_no, ": unknown list type"));
        }
      } else {
        p.type = type;
        ls >> p.name;
        if (!ParseType(p.type, &t)) {
          throw Error(
              StrCat(file, ": header line ", line_no, ": unknown property type '", type, "'"));
        }
      }
      if (p.name.empty())
        throw Error(StrCat(file, ": header line ", line_no, ": unnamed property"));
      h.elements.back().properties.push_back(p);
    } else if (key == "end_header") {
      ended = true;
      break;
    } else if (!key.empty()) {
      throw Error(StrCat(file, ": header line ", line_no, ": unknown keyword '", key, "'"));
    }
  }
  if (!ended) throw Error(StrCat(file, ": truncated header (no end_header)"));
  if (h.format.empty()) throw Error(StrCat(file, ": header has no format line"));
  // An organized cloud holds at most one vertex per grid cell: more means the grid comment does
  // not describe this file, and every reader (organized or not) refuses it rather than guess.
  if (h.grid_width > 0) {
    for (const PlyElement& e : h.elements) {
      if (e.name != "vertex") continue;
      if (static_cast<double>(h.grid_width) * h.grid_height < static_cast<double>(e.count)) {
        throw Error(StrCat(file, ": the fringe_grid comment says ", h.grid_width, " x ",
                           h.grid_height, " but the file declares ", e.count, " vertices"));
      }
    }
  }
  *body_offset = pos;
  return h;
}

// Reads values from the body, ASCII or binary; every read names the element item and property
// when the data runs out.
class BodyReader {
 public:
  BodyReader(const std::string& data, size_t offset, const std::string& format,
             const std::string& file)
      : data_(data), pos_(offset), file_(file) {
    ascii_ = format == "ascii";
    swap_ = format == "binary_big_endian";
  }

  double Read(Type t, const char* element, size_t item, const std::string& prop) {
    if (ascii_) return ReadAscii(element, item, prop);
    const size_t n = TypeSize(t);
    if (pos_ + n > data_.size()) {
      throw Error(StrCat(file_, ": truncated: data ends in ", element, " ", item, " (property ",
                         prop, ")"));
    }
    unsigned char b[8];
    std::memcpy(b, data_.data() + pos_, n);
    if (swap_) std::reverse(b, b + n);
    pos_ += n;
    switch (t) {
      case Type::kInt8:
        return static_cast<int8_t>(b[0]);
      case Type::kUInt8:
        return b[0];
      case Type::kInt16: {
        int16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case Type::kUInt16: {
        uint16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case Type::kInt32: {
        int32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case Type::kUInt32: {
        uint32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case Type::kFloat32: {
        float v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case Type::kFloat64: {
        double v;
        std::memcpy(&v, b, 8);
        return v;
      }
    }
    return 0;
  }

 private:
  double ReadAscii(const char* element, size_t item, const std::string& prop) {
    while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
    if (pos_ >= data_.size()) {
      throw Error(StrCat(file_, ": truncated: data ends in ", element, " ", item, " (property ",
                         prop, ")"));
    }
    const char* begin = data_.c_str() + pos_;
    char* end = nullptr;
    const double v = std::strtod(begin, &end);
    if (end == begin) {
      throw Error(StrCat(file_, ": bad number '",
                         std::string(begin, std::min<size_t>(12, std::strlen(begin))), "' in ",
                         element, " ", item, " (property ", prop, ")"));
    }
    pos_ += static_cast<size_t>(end - begin);
    return v;
  }

  const std::string& data_;
  size_t pos_;
  std::string file_;
  bool ascii_ = false;
  bool swap_ = false;
};

struct VertexSlots {
  int x = -1, y = -1, z = -1, nx = -1, ny = -1, nz = -1, r = -1, g = -1, b = -1;
  int intensity = -1, quality = -1, residual = -1, grid = -1;
  bool color_is_float = false;
};

VertexSlots FindVertexSlots(const PlyElement& e) {
  VertexSlots s;
  for (size_t i = 0; i < e.properties.size(); ++i) {
    const std::string& n = e.properties[i].name;
    const int k = static_cast<int>(i);
    if (!e.properties[i].list_count_type.empty()) continue;
    if (n == "x")
      s.x = k;
    else if (n == "y")
      s.y = k;
    else if (n == "z")
      s.z = k;
    else if (n == "nx")
      s.nx = k;
    else if (n == "ny")
      s.ny = k;
    else if (n == "nz")
      s.nz = k;
    else if (n == "red" || n == "r" || n == "diffuse_red")
      s.r = k;
    else if (n == "green" || n == "g" || n == "diffuse_green")
      s.g = k;
    else if (n == "blue" || n == "b" || n == "diffuse_blue")
      s.b = k;
    else if (n == "intensity" || n == "scalar_intensity")
      s.intensity = k;
    else if (n == "quality" || n == "confidence" || n == "scalar_quality")
      s.quality = k;
    else if (n == "residual_px")
      s.residual = k;
    else if (n == "grid_index")
      s.grid = k;
  }
  if (s.r >= 0) {
    const std::string& t = e.properties[s.r].type;
    s.color_is_float = t == "float" || t == "float32" || t == "double" || t == "float64";
  }
  return s;
}

// Every declared item takes at least a known number of bytes (binary: its fixed-size properties
// and list counts; ASCII: one character per value), so the counts in a header of a few hundred
// bytes are checked against the data actually present before anything is allocated from them.
void CheckCountsAgainstFileSize(const PlyHeader& h, size_t body_bytes, const std::string& file) {
  const bool ascii = h.format == "ascii";
  long double needed = 0;
  for (const PlyElement& e : h.elements) {
    size_t item_bytes = 0;
    for (const PlyProperty& p : e.properties) {
      Type t = Type::kUInt8;  // the header parser has already checked every type name
      ParseType(p.list_count_type.empty() ? p.type : p.list_count_type, &t);
      item_bytes += ascii ? 1 : TypeSize(t);
    }
    needed += static_cast<long double>(e.count) * item_bytes;
    if (needed > body_bytes) {
      throw Error(StrCat(file, ": truncated or inconsistent: header declares ", e.count, " ",
                         e.name, " items needing at least ", static_cast<double>(needed),
                         " bytes, the file holds ", body_bytes, " bytes of data"));
    }
  }
}

}  // namespace

PlyHeader ReadPlyHeader(const std::filesystem::path& path) {
  util::RequireFile(path, "PLY");
  // The header is small; read up to 64 KiB.
  std::ifstream in(path, std::ios::binary);
  std::string data(65536, '\0');
  in.read(data.data(), static_cast<std::streamsize>(data.size()));
  data.resize(static_cast<size_t>(in.gcount()));
  size_t offset = 0;
  return ParseHeader(data, path.string(), &offset);
}

PlyData ReadPly(const std::filesystem::path& path) {
  const std::string file = path.string();
  // Clouds can be large; the whole file is held in memory once, so its real size is the bound.
  const std::string data = util::ReadTextFile(path, std::numeric_limits<std::uintmax_t>::max());
  size_t offset = 0;
  PlyData out;
  out.header = ParseHeader(data, file, &offset);
  CheckCountsAgainstFileSize(out.header, data.size() - offset, file);
  BodyReader reader(data, offset, out.header.format, file);
  bool have_vertices = false;
  for (const PlyElement& e : out.header.elements) {
    std::vector<Type> types(e.properties.size()), count_types(e.properties.size());
    for (size_t i = 0; i < e.properties.size(); ++i) {
      ParseType(e.properties[i].type, &types[i]);
      if (!e.properties[i].list_count_type.empty()) {
        ParseType(e.properties[i].list_count_type, &count_types[i]);
      }
    }
    const char* ename = e.name.c_str();
    if (e.name == "vertex") {
      const VertexSlots s = FindVertexSlots(e);
      if (s.x < 0 || s.y < 0 || s.z < 0) {
        throw Error(StrCat(file, ": vertex element lacks x, y or z"));
      }
      have_vertices = true;
      PointCloud& c = out.cloud;
      c.points.resize(e.count);
      const bool normals = s.nx >= 0 && s.ny >= 0 && s.nz >= 0;
      const bool colors = s.r >= 0 && s.g >= 0 && s.b >= 0;
      if (normals) c.normals.resize(e.count);
      if (colors) c.colors.resize(e.count);
      if (s.intensity >= 0) c.intensity.resize(e.count);
      if (s.quality >= 0) c.quality.resize(e.count);
      if (s.residual >= 0) c.residual_px.resize(e.count);
      if (s.grid >= 0) out.grid_index.resize(e.count);
      std::vector<double> v(e.properties.size());
      for (size_t item = 0; item < e.count; ++item) {
        for (size_t p = 0; p < e.properties.size(); ++p) {
          if (e.properties[p].list_count_type.empty()) {
            v[p] = reader.Read(types[p], ename, item, e.properties[p].name);
          } else {
            const double n = reader.Read(count_types[p], ename, item, e.properties[p].name);
            if (!(n >= 0 && n <= 1e6)) {
              throw Error(StrCat(file, ": ", ename, " ", item, ": bad list length ", n));
            }
            for (int k = 0; k < static_cast<int>(n); ++k) {
              reader.Read(types[p], ename, item, e.properties[p].name);
            }
          }
        }
        c.points[item] = {v[s.x], v[s.y], v[s.z]};
        if (normals) c.normals[item] = {v[s.nx], v[s.ny], v[s.nz]};
        if (colors) {
          const double scale = s.color_is_float ? 255.0 : 1.0;
          for (int k = 0; k < 3; ++k) {
            const double cv = v[k == 0 ? s.r : k == 1 ? s.g : s.b] * scale;
            c.colors[item][k] = static_cast<uint8_t>(std::clamp(std::lround(cv), 0L, 255L));
          }
        }
        if (s.intensity >= 0) c.intensity[item] = static_cast<float>(v[s.intensity]);
        if (s.quality >= 0) c.quality[item] = static_cast<float>(v[s.quality]);
        if (s.residual >= 0) c.residual_px[item] = static_cast<float>(v[s.residual]);
        if (s.grid >= 0) {
          const double g = v[s.grid];
          if (!(g >= 0 && g < 4294967296.0)) {
            throw Error(StrCat(file, ": vertex ", item, ": bad grid_index ", g));
          }
          out.grid_index[item] = static_cast<uint32_t>(g);
        }
      }
    } else {
      // An element without properties holds no bytes, so its count is bounded by nothing in the
      // file: looping over a declared 10^11 of them would hang (found by fuzzing).
      if (e.properties.empty()) continue;
      int face_list = -1;
      if (e.name == "face") {
        for (size_t p = 0; p < e.properties.size(); ++p) {
          const std::string& n = e.properties[p].name;
          if (!e.properties[p].list_count_type.empty() &&
              (n == "vertex_indices" || n == "vertex_index")) {
            face_list = static_cast<int>(p);
          }
        }
      }
      std::vector<int64_t> poly;
      for (size_t item = 0; item < e.count; ++item) {
        for (size_t p = 0; p < e.properties.size(); ++p) {
          if (e.properties[p].list_count_type.empty()) {
            reader.Read(types[p], ename, item, e.properties[p].name);
            continue;
          }
          const double n = reader.Read(count_types[p], ename, item, e.properties[p].name);
          if (!(n >= 0 && n <= 1e6)) {
            throw Error(StrCat(file, ": ", ename, " ", item, ": bad list length ", n));
          }
          poly.clear();
          const bool is_face = static_cast<int>(p) == face_list;
          for (int k = 0; k < static_cast<int>(n); ++k) {
            const double v = reader.Read(types[p], ename, item, e.properties[p].name);
            if (!is_face) continue;
            // Checked as a double: an ASCII value such as 6e49 must not reach the integer cast
            // (undefined behaviour; found by fuzzing).
            if (!(v >= 0 && v < static_cast<double>(out.cloud.size())) || v != std::floor(v)) {
              throw Error(StrCat(file, ": face ", item, ": vertex index ", v,
                                 " out of range or not an integer (", out.cloud.size(),
                                 " vertices)"));
            }
            poly.push_back(static_cast<int64_t>(v));
          }
          if (!is_face) continue;
          for (size_t k = 2; k < poly.size(); ++k) {
            out.triangles.push_back({static_cast<int32_t>(poly[0]),
                                     static_cast<int32_t>(poly[k - 1]),
                                     static_cast<int32_t>(poly[k])});
          }
        }
      }
    }
  }
  if (!have_vertices) throw Error(StrCat(file, ": no vertex element"));
  return out;
}

OrganizedPointCloud ReadOrganizedPly(const std::filesystem::path& path) {
  PlyData d = ReadPly(path);
  const int w = d.header.grid_width, h = d.header.grid_height;
  if (w <= 0 || h <= 0 || d.grid_index.size() != d.cloud.size()) {
    throw Error(StrCat(path.string(),
                       ": not an organized cloud (no fringe_grid comment or "
                       "grid_index property)"));
  }
  OrganizedPointCloud grid(w, h, d.cloud.has_normals(), d.cloud.has_intensity(),
                           d.cloud.has_quality());
  if (d.cloud.has_colors()) grid.cloud.colors.assign(grid.valid.size(), Color3u8{0, 0, 0});
  if (d.cloud.has_residual()) {
    grid.cloud.residual_px.assign(grid.valid.size(), std::numeric_limits<float>::quiet_NaN());
  }
  for (size_t i = 0; i < d.cloud.size(); ++i) {
    const uint32_t g = d.grid_index[i];
    if (g >= grid.valid.size()) {
      throw Error(StrCat(path.string(), ": vertex ", i, ": grid_index ", g, " outside the ", w, "x",
                         h, " grid"));
    }
    grid.valid[g] = 1;
    grid.cloud.points[g] = d.cloud.points[i];
    if (d.cloud.has_normals()) grid.cloud.normals[g] = d.cloud.normals[i];
    if (d.cloud.has_colors()) grid.cloud.colors[g] = d.cloud.colors[i];
    if (d.cloud.has_intensity()) grid.cloud.intensity[g] = d.cloud.intensity[i];
    if (d.cloud.has_quality()) grid.cloud.quality[g] = d.cloud.quality[i];
    if (d.cloud.has_residual()) grid.cloud.residual_px[g] = d.cloud.residual_px[i];
  }
  return grid;
}

TriangleMesh ReadPlyMesh(const std::filesystem::path& path) {
  PlyData d = ReadPly(path);
  TriangleMesh m;
  m.vertices = std::move(d.cloud.points);
  m.normals = std::move(d.cloud.normals);
  m.colors = std::move(d.cloud.colors);
  m.triangles = std::move(d.triangles);
  m.Check(path.string());
  return m;
}

namespace {

// Writes the vertices `indices` of `cloud` (all when empty) with optional grid indices.
void WritePlyImpl(const std::filesystem::path& path, const PointCloud& cloud,
                  const std::vector<uint32_t>* grid_index, int grid_w, int grid_h,
                  const std::vector<TriangleMesh::Triangle>& triangles, PlyFormat format,
                  const std::vector<std::string>& comments) {
  cloud.CheckConsistent();
  static_assert(sizeof(float) == 4, "PLY float must be 4 bytes");
  const size_t n = grid_index ? grid_index->size() : cloud.size();
  auto src = [&](size_t i) { return grid_index ? (*grid_index)[i] : i; };
  util::WriteAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw Error(StrCat(path.string(), ": cannot open for writing"));
    const bool ascii = format == PlyFormat::kAscii;
    out << "ply\nformat " << (ascii ? "ascii" : "binary_little_endian") << " 1.0\n";
    out << "comment written by fringe; units: millimetres\n";
    for (const auto& c : comments) out << "comment " << c << "\n";
    if (grid_index) out << "comment fringe_grid " << grid_w << " " << grid_h << "\n";
    out << "element vertex " << n << "\n";
    out << "property float x\nproperty float y\nproperty float z\n";
    if (cloud.has_normals()) out << "property float nx\nproperty float ny\nproperty float nz\n";
    if (cloud.has_colors())
      out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    if (cloud.has_intensity()) out << "property float intensity\n";
    if (cloud.has_quality()) out << "property float quality\n";
    if (cloud.has_residual()) out << "property float residual_px\n";
    if (grid_index) out << "property uint grid_index\n";
    if (!triangles.empty()) {
      out << "element face " << triangles.size() << "\nproperty list uchar int vertex_indices\n";
    }
    out << "end_header\n";
    // Binary records are copied into a fixed buffer written out every ~1 MiB (a vertex record
    // is at most 44 bytes, a face 13): no per-value vector growth on million-point clouds.
    constexpr size_t kFlushBytes = size_t{1} << 20;
    std::vector<char> buf(kFlushBytes + 256);
    size_t used = 0;
    auto put = [&](const auto& v) {
      std::memcpy(buf.data() + used, &v, sizeof(v));
      used += sizeof(v);
    };
    auto flush = [&](size_t at_least) {
      if (used < at_least) return;
      out.write(buf.data(), static_cast<std::streamsize>(used));
      used = 0;
    };
    out.precision(9);
    for (size_t k = 0; k < n; ++k) {
      const size_t i = src(k);
      const Eigen::Vector3f p = cloud.points[i].cast<float>();
      if (ascii) {
        out << p.x() << " " << p.y() << " " << p.z();
        if (cloud.has_normals()) {
          const Eigen::Vector3f q = cloud.normals[i].cast<float>();
          out << " " << q.x() << " " << q.y() << " " << q.z();
        }
        if (cloud.has_colors()) {
          out << " " << int(cloud.colors[i][0]) << " " << int(cloud.colors[i][1]) << " "
              << int(cloud.colors[i][2]);
        }
        if (cloud.has_intensity()) out << " " << cloud.intensity[i];
        if (cloud.has_quality()) out << " " << cloud.quality[i];
        if (cloud.has_residual()) out << " " << cloud.residual_px[i];
        if (grid_index) out << " " << i;
        out << "\n";
      } else {
        put(p.x()), put(p.y()), put(p.z());
        if (cloud.has_normals()) {
          const Eigen::Vector3f q = cloud.normals[i].cast<float>();
          put(q.x()), put(q.y()), put(q.z());
        }
        if (cloud.has_colors()) put(cloud.colors[i]);
        if (cloud.has_intensity()) put(cloud.intensity[i]);
        if (cloud.has_quality()) put(cloud.quality[i]);
        if (cloud.has_residual()) put(cloud.residual_px[i]);
        if (grid_index) put(static_cast<uint32_t>(i));
        flush(kFlushBytes);
      }
    }
    for (const auto& t : triangles) {
      for (int32_t idx : t) {
        if (idx < 0 || static_cast<size_t>(idx) >= n) {
          throw Error(StrCat(path.string(), ": triangle vertex index ", idx, " out of range"));
        }
      }
      if (ascii) {
        out << "3 " << t[0] << " " << t[1] << " " << t[2] << "\n";
      } else {
        put(static_cast<uint8_t>(3));
        put(t[0]), put(t[1]), put(t[2]);
        flush(kFlushBytes);
      }
    }
    flush(1);
    util::CloseOutput(out, path);
  });
}

}  // namespace

void WritePly(const std::filesystem::path& path, const PointCloud& cloud, PlyFormat format,
              const std::vector<std::string>& comments) {
  WritePlyImpl(path, cloud, nullptr, 0, 0, {}, format, comments);
}

void WritePly(const std::filesystem::path& path, const TriangleMesh& mesh, PlyFormat format,
              const std::vector<std::string>& comments) {
  mesh.Check(path.string());
  // The writer's vertex record is the cloud's; the copy costs one pass over the vertices.
  PointCloud cloud;
  cloud.points = mesh.vertices;
  cloud.normals = mesh.normals;
  cloud.colors = mesh.colors;
  WritePlyImpl(path, cloud, nullptr, 0, 0, mesh.triangles, format, comments);
}

void WritePly(const std::filesystem::path& path, const OrganizedPointCloud& grid, PlyFormat format,
              const std::vector<std::string>& comments) {
  grid.CheckConsistent();
  std::vector<uint32_t> idx;
  idx.reserve(grid.NumValid());
  for (size_t i = 0; i < grid.valid.size(); ++i) {
    if (grid.valid[i]) idx.push_back(static_cast<uint32_t>(i));
  }
  WritePlyImpl(path, grid.cloud, &idx, grid.width, grid.height, {}, format, comments);
}

}  // namespace fringe::io
