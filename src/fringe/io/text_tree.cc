#include "fringe/io/text_tree.h"

#include <tinyxml2.h>
#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <unordered_set>

#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace {

namespace fs = std::filesystem;
using util::StrCat;

class Builder {
 public:
  Builder(const fs::path& path, const TextTreeLimits& limits) : path_(path), limits_(limits) {}

  [[noreturn]] void Fail(int line, const std::string& what) const {
    if (line > 0) throw Error(StrCat(path_.string(), ": line ", line, ": ", what));
    throw Error(StrCat(path_.string(), ": ", what));
  }

  void Count(int depth, int line) {
    if (depth > limits_.max_depth) {
      Fail(line, StrCat("nested deeper than ", limits_.max_depth,
                        " levels (no calibration file needs that)"));
    }
    if (++nodes_ > limits_.max_nodes) {
      Fail(line, StrCat("more than ", limits_.max_nodes,
                        " values (after expanding YAML aliases); not a calibration file"));
    }
  }

  void SetScalar(TextNode* out, std::string value, int line) const {
    if (value.size() > limits_.max_scalar_bytes) {
      Fail(line, StrCat("a value of ", value.size(), " bytes (at most ", limits_.max_scalar_bytes,
                        " expected)"));
    }
    out->kind = TextNode::Kind::kScalar;
    out->scalar = std::move(value);
  }

  void FromYaml(const YAML::Node& n, int depth, TextNode* out) {
    const int line = n.Mark().is_null() ? 0 : n.Mark().line + 1;
    Count(depth, line);
    out->line = line;
    switch (n.Type()) {
      case YAML::NodeType::Undefined:
      case YAML::NodeType::Null:
        out->kind = TextNode::Kind::kNull;
        return;
      case YAML::NodeType::Scalar:
        SetScalar(out, n.Scalar(), line);
        return;
      case YAML::NodeType::Sequence:
        out->kind = TextNode::Kind::kSeq;
        for (const YAML::Node& item : n) {
          out->items.emplace_back();
          FromYaml(item, depth + 1, &out->items.back());
        }
        return;
      case YAML::NodeType::Map: {
        out->kind = TextNode::Kind::kMap;
        std::unordered_set<std::string> seen;
        for (auto it = n.begin(); it != n.end(); ++it) {
          if (!it->first.IsScalar()) Fail(line, "a mapping key that is not a plain name");
          const std::string key = it->first.Scalar();
          if (!seen.insert(key).second) {
            Fail(it->first.Mark().line + 1, StrCat("key '", key, "' appears twice in one mapping"));
          }
          out->fields.emplace_back(key, TextNode{});
          FromYaml(it->second, depth + 1, &out->fields.back().second);
        }
        return;
      }
    }
  }

  // OpenCV writes sequences and matrix data as whitespace-separated numbers in one element.
  static std::vector<std::string> Tokens(const char* text) {
    std::vector<std::string> tokens;
    std::istringstream is(text ? text : "");
    for (std::string t; is >> t;) tokens.push_back(t);
    return tokens;
  }

  void FromXml(const tinyxml2::XMLElement& e, int depth, bool in_matrix, TextNode* out) {
    const int line = e.GetLineNum();
    Count(depth, line);
    out->line = line;
    if (e.FirstChildElement() != nullptr) {
      out->kind = TextNode::Kind::kMap;
      const char* type = e.Attribute("type_id");
      const bool matrix = type != nullptr && std::string(type) == "opencv-matrix";
      std::unordered_set<std::string> seen;
      for (const tinyxml2::XMLElement* c = e.FirstChildElement(); c != nullptr;
           c = c->NextSiblingElement()) {
        const std::string key = c->Name();
        if (!seen.insert(key).second) {
          Fail(c->GetLineNum(), StrCat("element <", key, "> appears twice in <", e.Name(), ">"));
        }
        out->fields.emplace_back(key, TextNode{});
        FromXml(*c, depth + 1, matrix && key == "data", &out->fields.back().second);
      }
      return;
    }
    std::vector<std::string> tokens = Tokens(e.GetText());
    if (tokens.empty()) {
      out->kind = TextNode::Kind::kNull;
      return;
    }
    // A matrix's data, or several numbers in one element (an OpenCV sequence): a sequence.
    if (in_matrix || tokens.size() > 1) {
      bool numbers = true;
      for (const auto& t : tokens) {
        char* end = nullptr;
        std::strtod(t.c_str(), &end);
        numbers = numbers && end != t.c_str() && *end == '\0';
      }
      if (numbers || in_matrix) {
        out->kind = TextNode::Kind::kSeq;
        for (auto& t : tokens) {
          Count(depth + 1, line);
          out->items.emplace_back();
          SetScalar(&out->items.back(), std::move(t), line);
          out->items.back().line = line;
        }
        return;
      }
    }
    SetScalar(out, e.GetText(), line);
    // Names keep their inner spaces but not the surrounding layout.
    const size_t b = out->scalar.find_first_not_of(" \t\r\n");
    const size_t l = out->scalar.find_last_not_of(" \t\r\n");
    out->scalar = out->scalar.substr(b, l - b + 1);
  }

 private:
  const fs::path& path_;
  const TextTreeLimits& limits_;
  int64_t nodes_ = 0;
};

}  // namespace

const TextNode* TextNode::Find(const std::string& key) const {
  if (kind != Kind::kMap) return nullptr;
  for (const auto& [k, v] : fields) {
    if (k == key) return &v;
  }
  return nullptr;
}

std::optional<double> TextNode::Number() const {
  if (kind != Kind::kScalar || scalar.empty()) return std::nullopt;
  const char* s = scalar.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s, &end);
  if (end == s || *end != '\0' || errno == ERANGE || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<long long> TextNode::Integer() const {
  const std::optional<double> v = Number();
  if (!v || *v != std::floor(*v) || std::fabs(*v) > 1e15) return std::nullopt;
  return static_cast<long long>(*v);
}

TextTree ReadTextTree(const fs::path& path, const TextTreeLimits& limits) {
  util::RequireFile(path, "calibration");
  const std::uintmax_t size = util::FileSizeBytes(path);
  if (size > limits.max_bytes) {
    throw Error(StrCat(path.string(), ": ", size, " bytes, more than the ", limits.max_bytes,
                       " a calibration file can plausibly need"));
  }
  std::string text = util::ReadTextFile(path, limits.max_bytes);
  // Calibration files are text; a NUL would end the parsers' view of the file early.
  if (text.find('\0') != std::string::npos) {
    throw Error(StrCat(path.string(), ": holds a NUL byte: not a text calibration file"));
  }
  TextTree tree;
  tree.path = path;
  Builder builder(path, limits);
  const size_t first = text.find_first_not_of(" \t\r\n");
  tree.xml = first != std::string::npos && text[first] == '<';
  if (tree.xml) {
    tinyxml2::XMLDocument doc;
    if (doc.Parse(text.data(), text.size()) != tinyxml2::XML_SUCCESS) {
      builder.Fail(doc.ErrorLineNum(), StrCat("not valid XML: ", doc.ErrorStr()));
    }
    const tinyxml2::XMLElement* root = doc.RootElement();
    if (root == nullptr) builder.Fail(0, "no XML element");
    tree.opencv_header = std::string(root->Name()) == "opencv_storage";
    builder.FromXml(*root, 0, false, &tree.root);
    if (tree.root.kind == TextNode::Kind::kNull) tree.root.kind = TextNode::Kind::kMap;
  } else {
    // yaml-cpp recurses once per flow bracket before its own depth guard; refuse deep brackets
    // up front so the limit is ours and does not depend on the stack size.
    int flow = 0;
    bool quote = false;
    char q = 0;
    for (const char c : text) {
      if (quote) {
        quote = c != q && c != '\n';
      } else if (c == '"' || c == '\'') {
        quote = true;
        q = c;
      } else if ((c == '[' || c == '{') && ++flow > limits.max_depth) {
        builder.Fail(0, StrCat("brackets nested deeper than ", limits.max_depth, " levels"));
      } else if (c == ']' || c == '}') {
        flow = std::max(0, flow - 1);
      }
    }
    // OpenCV writes "%YAML:1.0", which YAML 1.2 parsers refuse; it carries nothing else.
    if (text.rfind("%YAML:", 0) == 0 || text.rfind("%YAML 1.0", 0) == 0) {
      tree.opencv_header = true;
      text[0] = '#';
    }
    YAML::Node doc;
    try {
      doc = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      builder.Fail(e.mark.is_null() ? 0 : e.mark.line + 1, StrCat("not valid YAML: ", e.msg));
    }
    if (doc.IsNull()) {
      tree.root.kind = TextNode::Kind::kMap;
    } else if (!doc.IsMap()) {
      builder.Fail(0, "the top level is not a mapping of keys to values");
    } else {
      builder.FromYaml(doc, 0, &tree.root);
    }
  }
  return tree;
}

std::optional<TextMatrix> ToMatrix(const TextNode& node, std::string* why) {
  constexpr int kMaxSide = 64;
  const auto fail = [&](const std::string& what) -> std::optional<TextMatrix> {
    if (why) *why = what;
    return std::nullopt;
  };
  const auto numbers = [&](const TextNode& seq, TextMatrix* m) {
    for (const TextNode& v : seq.items) {
      const std::optional<double> x = v.Number();
      if (!x) return false;
      m->data.push_back(*x);
    }
    return true;
  };
  TextMatrix m;
  if (node.IsMap()) {
    const TextNode *rows = node.Find("rows"), *cols = node.Find("cols"), *data = node.Find("data");
    if (!rows || !cols || !data) return fail("not a matrix (expected rows, cols and data)");
    const auto r = rows->Integer(), c = cols->Integer();
    if (!r || !c || *r < 1 || *c < 1 || *r > kMaxSide || *c > kMaxSide) {
      return fail(StrCat("rows and cols must be integers in [1, ", kMaxSide, "]"));
    }
    // With 8- or 16-bit integer elements cv::FileStorage saturates a focal length of 2400 to
    // 255: the values written are not what other readers of the file see.
    if (const TextNode* dt = node.Find("dt"); dt && dt->IsScalar()) {
      if (dt->scalar != "d" && dt->scalar != "f" && dt->scalar != "i") {
        return fail(StrCat("element type dt: ", dt->scalar, " (expected d or f, floating point)"));
      }
    }
    m.rows = static_cast<int>(*r);
    m.cols = static_cast<int>(*c);
    if (data->IsScalar()) {
      TextNode seq;
      seq.kind = TextNode::Kind::kSeq;
      seq.items.push_back(*data);
      if (!numbers(seq, &m)) return fail("data holds a value that is not a finite number");
    } else if (!data->IsSeq() || !numbers(*data, &m)) {
      return fail("data holds a value that is not a finite number");
    }
    if (m.data.size() != static_cast<size_t>(m.rows * m.cols)) {
      return fail(
          StrCat("data holds ", m.data.size(), " numbers, rows x cols = ", m.rows, " x ", m.cols));
    }
    return m;
  }
  if (!node.IsSeq() || node.items.empty()) return fail("not a matrix or a list of numbers");
  if (node.items[0].IsSeq()) {
    m.rows = static_cast<int>(node.items.size());
    m.cols = static_cast<int>(node.items[0].items.size());
    if (m.rows > kMaxSide || m.cols < 1 || m.cols > kMaxSide) return fail("matrix too large");
    for (const TextNode& row : node.items) {
      if (!row.IsSeq() || static_cast<int>(row.items.size()) != m.cols) {
        return fail("rows of different lengths");
      }
      if (!numbers(row, &m)) return fail("a value that is not a finite number");
    }
    return m;
  }
  m.rows = 1;
  m.cols = static_cast<int>(node.items.size());
  if (m.cols > kMaxSide * kMaxSide) return fail("list too long");
  if (!numbers(node, &m)) return fail("a value that is not a finite number");
  return m;
}

}  // namespace fringe::io
