#include "fringe/io/opencv_calibration.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <sstream>
#include <string>
#include <string_view>

#include "fringe/io/calibration_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace {

namespace fs = std::filesystem;
using util::StrCat;

constexpr std::uintmax_t kMaxOpenCvFileBytes = std::uintmax_t{16} << 20;
constexpr int kMaxIndentColumns = 512;

// Key spellings, most common first. Matched exactly (OpenCV keys are case sensitive).
const std::vector<std::string> kLeftK = {"M1",
                                         "K1",
                                         "cameraMatrix1",
                                         "cameraMatrixL",
                                         "camera_matrix_left",
                                         "cameraMatrixLeft",
                                         "K_left",
                                         "KL",
                                         "Kl",
                                         "M_l",
                                         "leftCameraMatrix",
                                         "camera_matrix",
                                         "cameraMatrix",
                                         "K"};
const std::vector<std::string> kLeftD = {"D1",
                                         "distCoeffs1",
                                         "distCoeffsL",
                                         "dist_coeffs_left",
                                         "distCoeffsLeft",
                                         "D_left",
                                         "DL",
                                         "Dl",
                                         "D_l",
                                         "leftDistCoeffs",
                                         "distortion_coefficients",
                                         "dist_coeffs",
                                         "distCoeffs",
                                         "D"};
const std::vector<std::string> kRightK = {"M2",
                                          "K2",
                                          "cameraMatrix2",
                                          "cameraMatrixR",
                                          "camera_matrix_right",
                                          "cameraMatrixRight",
                                          "K_right",
                                          "KR",
                                          "Kr",
                                          "M_r",
                                          "rightCameraMatrix"};
const std::vector<std::string> kRightD = {
    "D2", "distCoeffs2", "distCoeffsR", "dist_coeffs_right", "distCoeffsRight", "D_right",
    "DR", "Dr",          "D_r",         "rightDistCoeffs"};
const std::vector<std::string> kProjK = {"M3",
                                         "M4",
                                         "K3",
                                         "K4",
                                         "Kp",
                                         "K_p",
                                         "KP",
                                         "Mp",
                                         "projectorMatrix",
                                         "cameraMatrixP",
                                         "camera_matrix_projector",
                                         "projector_matrix",
                                         "K_projector",
                                         "projectorCameraMatrix"};
const std::vector<std::string> kProjD = {"D3",          "D4",
                                         "Dp",          "D_p",
                                         "DP",          "projectorDistCoeffs",
                                         "distCoeffsP", "dist_coeffs_projector",
                                         "D_projector"};
const std::vector<std::string> kRightR = {"R", "Rlr", "R_l2r", "R_lr", "R12", "Rl2r", "R_LR"};
const std::vector<std::string> kRightT = {"T", "Tlr", "T_l2r", "T_lr", "T12", "Tl2r", "T_LR"};
const std::vector<std::string> kProjR = {"Rlp",  "R_l2p", "R_lp", "R13",
                                         "Rl2p", "R_LP",  "Rp",   "R_p"};
const std::vector<std::string> kProjT = {"Tlp",  "T_l2p", "T_lp", "T13",
                                         "Tl2p", "T_LP",  "Tp",   "T_p"};

// A value found in one of the files.
struct Found {
  fs::path file;
  std::string key;
  cv::Mat m;  // CV_64F, one row
};

// An !!opencv-matrix node read by hand: OpenCV's own reader allocates rows x cols from the
// file before it looks at the data, so a malformed header (fuzzing found "cols:atrix" read as
// ~2^34) could ask for tens of gigabytes. Calibration matrices are small: rows and cols are
// integers in [1, kMaxSide] and `data` must hold exactly rows x cols numbers. Returns an empty
// matrix when the node is not such a matrix.
cv::Mat ReadMatrixNode(const cv::FileNode& n, std::string* why = nullptr) {
  constexpr int kMaxSide = 64;
  const cv::FileNode rows = n["rows"], cols = n["cols"], data = n["data"];
  if (!rows.isInt() || !cols.isInt() || !data.isSeq()) return {};
  // The element type says how every other reader of the file sees the values: with 8- or 16-bit
  // integers ('u', 'c', 'w', 's') cv::FileStorage saturates a focal length of 2400 to 255, so
  // taking the written values would give a calibration other tools do not see.
  const cv::FileNode dt = n["dt"];
  if (dt.isString()) {
    const std::string t = static_cast<std::string>(dt);
    if (t != "d" && t != "f" && t != "i") {
      if (why) *why = StrCat("element type dt: ", t, " (expected d or f, floating point)");
      return {};
    }
  }
  const int r = static_cast<int>(rows), c = static_cast<int>(cols);
  if (r < 1 || c < 1 || r > kMaxSide || c > kMaxSide) return {};
  if (data.size() != static_cast<size_t>(r) * static_cast<size_t>(c)) return {};
  cv::Mat m(1, r * c, CV_64F);
  int i = 0;
  for (const cv::FileNode& v : data) {
    if (!v.isReal() && !v.isInt()) return {};
    m.at<double>(i++) = static_cast<double>(v);
  }
  return m;
}

class Files {
 public:
  explicit Files(const std::vector<fs::path>& paths) {
    for (const fs::path& p : paths) {
      util::RequireFile(p, "OpenCV calibration");
      CheckOpenCvFileBounds(p);
      auto storage = std::make_unique<cv::FileStorage>();
      try {
        storage->open(p.string(), cv::FileStorage::READ);
      } catch (const cv::Exception& e) {
        throw Error(StrCat(p.string(), ": cannot parse as OpenCV YAML/XML: ", e.err));
      }
      if (!storage->isOpened()) {
        throw Error(StrCat(p.string(), ": cannot parse as OpenCV YAML/XML"));
      }
      storages_.emplace_back(p, std::move(storage));
    }
  }

  // storage[key], with OpenCV's exception for a malformed document (found by fuzz_opencv)
  // turned into an error naming the file.
  static cv::FileNode Lookup(const fs::path& path, const cv::FileStorage& storage,
                             const std::string& key) {
    try {
      return storage[key];
    } catch (const cv::Exception& e) {
      throw Error(
          StrCat(path.string(), ": malformed OpenCV YAML/XML (looking up '", key, "'): ", e.err));
    }
  }

  // The first spelling present in any file; an error when two files (or two spellings) hold it.
  std::optional<Found> Matrix(const std::vector<std::string>& spellings, const char* what) const {
    std::optional<Found> found;
    for (const auto& [path, fs] : storages_) {
      for (const std::string& key : spellings) {
        const cv::FileNode node = Lookup(path, *fs, key);
        if (node.empty() || node.isNone()) continue;
        if (found) {
          throw Error(StrCat(path.string(), ": ", key, " and ", found->file.string(), ": ",
                             found->key, " both give the ", what,
                             "; keep one (fringe will not guess)"));
        }
        cv::Mat m;
        std::string why;
        try {
          if (!node.isMap() && !node.isSeq()) throw cv::Exception();
          if (node.isSeq()) {
            std::vector<double> v;
            node >> v;
            m = cv::Mat(v, true);
          } else {
            m = ReadMatrixNode(node, &why);
          }
        } catch (const cv::Exception&) {
          m = cv::Mat();
        }
        if (m.empty()) {
          throw Error(StrCat(
              path.string(), ": ", key, " (", what, "): ",
              why.empty() ? "not a matrix (expected !!opencv-matrix or a list of numbers)" : why));
        }
        m.convertTo(m, CV_64F);
        m = m.reshape(1, 1).clone();
        for (int i = 0; i < m.cols; ++i) {
          if (!std::isfinite(m.at<double>(i))) {
            throw Error(
                StrCat(path.string(), ": ", key, " (", what, "): entry ", i, " is not finite"));
          }
        }
        found = Found{path, key, m};
      }
    }
    return found;
  }

  // An integer pair (width, height) under one of the spellings, or {0, 0}.
  std::pair<int, int> Size(const std::vector<std::pair<std::string, std::string>>& pairs,
                           const std::vector<std::string>& vectors, std::string* source) const {
    for (const auto& [path, fs] : storages_) {
      for (const auto& [wk, hk] : pairs) {
        const cv::FileNode w = Lookup(path, *fs, wk), h = Lookup(path, *fs, hk);
        if (w.isInt() && h.isInt()) {
          *source = StrCat(path.filename().string(), ": ", wk, " ", hk);
          return {static_cast<int>(w), static_cast<int>(h)};
        }
      }
      for (const std::string& k : vectors) {
        const cv::FileNode n = Lookup(path, *fs, k);
        if (n.isSeq() && n.size() == 2 && n[0].isInt() && n[1].isInt()) {
          *source = StrCat(path.filename().string(), ": ", k);
          return {static_cast<int>(n[0]), static_cast<int>(n[1])};
        }
        if (n.isMap()) {
          // A 2-element !!opencv-matrix (SLMaster's "S: [1280., 1024.]").
          cv::Mat m;
          try {
            m = ReadMatrixNode(n);
          } catch (const cv::Exception&) {
            continue;
          }
          if (m.total() != 2 || m.channels() != 1) continue;
          m.convertTo(m, CV_64F);
          const double w = m.at<double>(0), h = m.at<double>(1);
          if (w >= 1 && h >= 1 && w <= util::kMaxImageSidePx && h <= util::kMaxImageSidePx &&
              w == std::floor(w) && h == std::floor(h)) {
            *source = StrCat(path.filename().string(), ": ", k);
            return {static_cast<int>(w), static_cast<int>(h)};
          }
        }
      }
    }
    return {0, 0};
  }

 private:
  std::vector<std::pair<fs::path, std::unique_ptr<cv::FileStorage>>> storages_;
};

std::string Where(const Found& f) { return StrCat(f.file.string(), ": ", f.key); }

CameraModel Camera(const Found& k, const std::optional<Found>& d, int width, int height,
                   const char* device) {
  std::vector<double> dist;
  if (d) dist.assign(d->m.ptr<double>(), d->m.ptr<double>() + d->m.cols);
  return CameraFromMatrices(std::vector<double>(k.m.ptr<double>(), k.m.ptr<double>() + k.m.cols),
                            d ? &dist : nullptr, width, height, device, Where(k),
                            d ? Where(*d) : std::string());
}

Rigid3d Extrinsics(const Found& r, const Found& t, const char* what) {
  return RigidFromMatrices(std::vector<double>(r.m.ptr<double>(), r.m.ptr<double>() + r.m.cols),
                           std::vector<double>(t.m.ptr<double>(), t.m.ptr<double>() + t.m.cols),
                           1.0, what, Where(r), Where(t));
}

}  // namespace

const std::vector<std::string>& OpenCvCameraMatrixSpellings() { return kLeftK; }

void CheckOpenCvFileBounds(const fs::path& path) {
  const std::uintmax_t size = util::FileSizeBytes(path);
  if (size > kMaxOpenCvFileBytes) {
    throw Error(StrCat(path.string(), ": ", size, " bytes, larger than the ", kMaxOpenCvFileBytes,
                       " bytes an OpenCV calibration file can plausibly need"));
  }
  const std::string text = util::ReadTextFile(path, kMaxOpenCvFileBytes);
  const auto fail = [&](int line, const std::string& what) {
    throw Error(StrCat(path.string(), ": line ", line, ": ", what));
  };
  // XML: OpenCV's parser dereferences null when the file ends inside a tag or an attribute has
  // no quoted value (SEGVs found by fuzz_opencv): every tag must close and every '=' in a tag
  // must open a quoted value that closes within it.
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text[first] == '<') {
    int line_no = 1;
    for (size_t i = 0; i < text.size(); ++i) {
      if (text[i] == '\n') ++line_no;
      if (text[i] != '<') continue;
      const size_t close = text.find('>', i);
      if (close == std::string::npos) fail(line_no, "an XML tag is not closed before the end");
      for (size_t k = i; k < close; ++k) {
        if (text[k] != '=') continue;
        size_t v = k + 1;
        while (v < close && (text[v] == ' ' || text[v] == '\t')) ++v;
        if (v >= close || (text[v] != '"' && text[v] != '\'')) {
          fail(line_no, "an XML attribute has no quoted value");
        }
        const size_t end = text.find(text[v], v + 1);
        if (end == std::string::npos || end > close) {
          fail(line_no, "an XML attribute value is not closed within its tag");
        }
        k = end;
      }
      for (size_t k = i; k < close; ++k) line_no += text[k] == '\n';
      i = close;
    }
  }
  // A top-level YAML key given twice: OpenCV silently keeps one of them, so a file edited by hand
  // (or hostile) would calibrate with values the user did not mean. Refused, naming both lines.
  if (text.find_first_not_of(" \t\r\n") != std::string::npos &&
      text[text.find_first_not_of(" \t\r\n")] != '<') {
    std::map<std::string, int> first_line;
    int n = 0;
    for (size_t pos = 0; pos < text.size();) {
      const size_t end = std::min(text.find('\n', pos), text.size());
      ++n;
      const std::string_view l(text.data() + pos, end - pos);
      const size_t colon = l.find(':');
      if (!l.empty() && std::isalpha(static_cast<unsigned char>(l[0])) &&
          colon != std::string_view::npos) {
        const std::string key(l.substr(0, colon));
        const auto [it, fresh] = first_line.emplace(key, n);
        if (!fresh)
          fail(n, StrCat("key '", key, "' appears twice (first on line ", it->second, ")"));
      }
      pos = end + 1;
    }
  }
  int line = 1, flow = 0, xml = 0;
  bool line_start = true, in_quote = false;
  int indent = 0, dashes = 0;
  char quote = 0;
  size_t next_close = 0;
  // YAML line structure: outside brackets every line of a calibration file is a key ("key:"), a
  // sequence item ("- "), a directive, document marker or comment. A bare value on a line of its
  // own below an indented mapping sends OpenCV's YAML parser into an endless loop (timeout found
  // by fuzz_opencv: " r: 1", "n0", "-"); OpenCV never writes such lines, so they are refused.
  const bool yaml = first == std::string::npos || text[first] != '<';
  int line_flow = 0;               // bracket depth at the start of the line
  size_t line_begin = 0;           // first byte of the line's content
  bool line_key = false;           // a ':' outside quotes ending the key
  std::vector<int> block_columns;  // columns of the open block levels, outermost first
  const auto end_line = [&](size_t end) {
    if (!yaml || line_flow > 0) return;
    const std::string_view l = std::string_view(text).substr(line_begin, end - line_begin);
    const size_t b = l.find_first_not_of(" \t\r");
    if (b == std::string_view::npos) return;
    const std::string_view content = l.substr(b);
    const auto is = [&](std::string_view marker) {
      return content.rfind(marker, 0) == 0 &&
             content.find_first_not_of(" \t\r", marker.size()) == std::string_view::npos;
    };
    // Document markers alone on their line, directives only at the top: "---- ." and
    // "--- - value" sent OpenCV's parser into endless loops too (fuzz_opencv).
    if ((content.rfind("---", 0) == 0 && !is("---")) ||
        (content.rfind("...", 0) == 0 && !is("..."))) {
      fail(line, "a document marker ('---' or '...') must stand alone on its line");
    }
    if (content[0] == '%' && !(content.rfind("%YAML", 0) == 0 && line == 1)) {
      fail(line, "a directive other than '%YAML' on the first line");
    }
    // Block indentation: top-level keys in the first column, and a line indented less than the
    // one before it must return to an enclosing level. An indented top level or a dedent to a
    // column no block opened is what sent OpenCV's parser into its endless loops.
    const int column = static_cast<int>(b);
    if (content[0] != '#' && content[0] != '%' && !is("---") && !is("...")) {
      if (block_columns.empty()) {
        if (column != 0) fail(line, "the top-level keys must start in the first column");
        block_columns.push_back(0);
      } else if (column > block_columns.back()) {
        block_columns.push_back(column);
      } else {
        while (block_columns.back() > column) block_columns.pop_back();
        if (block_columns.back() != column) {
          fail(line, "indentation returns to a column no enclosing block started at");
        }
      }
    }
    if (line_key || dashes > 0) return;
    if (content[0] == '#' || content[0] == '%' || is("---") || is("...") || is("-") ||
        content[0] == '[' || content[0] == '{') {
      return;
    }
    fail(line, "a value on a line of its own, outside a key, a '- ' item or brackets");
  };
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      end_line(i);
      ++line;
      line_start = true;
      indent = dashes = 0;
      in_quote = false;
      line_flow = flow;
      line_begin = i + 1;
      line_key = false;
      continue;
    }
    // Calibration files are text: a NUL or other control byte means a binary or corrupt file,
    // and OpenCV's XML parser dereferences null on some of them (SEGV found by fuzz_opencv).
    const unsigned char u = static_cast<unsigned char>(c);
    if ((u < 0x20 && c != '\t' && c != '\r') || u == 0x7f) {
      fail(line, StrCat("control byte 0x", "0123456789abcdef"[u >> 4], "0123456789abcdef"[u & 15],
                        ": not a text calibration file"));
    }
    if (in_quote) {
      if (c == quote) in_quote = false;
      continue;
    }
    if (line_start && c == ' ') {
      if (++indent > kMaxIndentColumns) fail(line, "indented deeper than fringe accepts");
      continue;
    }
    // An empty mapping key (a line whose first character is ':') makes OpenCV's YAML parser
    // abort the process (std::terminate inside cv::FileStorage; found by fuzz_opencv).
    if (line_start && c == ':') fail(line, "a mapping key is empty (the line starts with ':')");
    line_start = false;
    // "- " opens a nested block sequence, also several on one line ("key: - - - 1").
    if (c == '-' && i + 1 < text.size() && text[i + 1] == ' ' &&
        (i == 0 || text[i - 1] == ' ' || text[i - 1] == '\n')) {
      if (++dashes > util::kMaxNestingDepth) fail(line, "YAML sequences nested too deeply");
      continue;
    }
    if (c == ':' && flow == 0 &&
        (i + 1 == text.size() || text[i + 1] == ' ' || text[i + 1] == '\t' || text[i + 1] == '\r' ||
         text[i + 1] == '\n')) {
      line_key = true;
    }
    if (c == '"' || c == '\'') {
      in_quote = true;
      quote = c;
    } else if (c == '[' || c == '{') {
      if (++flow > util::kMaxNestingDepth) fail(line, "YAML brackets nested too deeply");
    } else if (c == ']' || c == '}') {
      if (yaml && flow == 0) fail(line, StrCat("'", std::string(1, c), "' closes no bracket"));
      flow = std::max(0, flow - 1);
    } else if (c == '<' && i + 1 < text.size()) {
      const char n = text[i + 1];
      if (n == '/') {
        xml = std::max(0, xml - 1);
      } else if (std::isalpha(static_cast<unsigned char>(n)) || n == '_') {
        // Self-closing "<a/>" does not nest.
        if (next_close != std::string::npos && next_close <= i) next_close = text.find('>', i);
        const size_t close = next_close;  // amortised: each '>' is found once
        if (close == std::string::npos || text[close - 1] != '/') {
          if (++xml > util::kMaxNestingDepth) fail(line, "XML elements nested too deeply");
        }
      }
    }
  }
  end_line(text.size());
  // Declared matrix sizes: OpenCV allocates rows x cols before reading the data, so a few bytes
  // could ask for gigabytes. Every element takes at least one byte of the file.
  for (const char* key : {"rows", "cols"}) {
    for (const std::string& pattern : {StrCat(key, ":"), StrCat("<", key, ">")}) {
      for (size_t pos = text.find(pattern); pos != std::string::npos;
           pos = text.find(pattern, pos + 1)) {
        const char* p = text.c_str() + pos + pattern.size();
        char* end = nullptr;
        const double v = std::strtod(p, &end);
        if (end == p) continue;
        if (!(v >= 0 && v <= static_cast<double>(size))) {
          const int l = 1 + static_cast<int>(std::count(text.begin(), text.begin() + pos, '\n'));
          fail(l, StrCat("matrix ", key, " = ", v, " exceeds what the file's ", size,
                         " bytes can hold"));
        }
      }
    }
  }
  // rows x cols together (both bounded above, so the product cannot overflow a double).
  size_t pos = 0;
  while ((pos = text.find("rows", pos)) != std::string::npos) {
    const size_t cpos = text.find("cols", pos);
    pos += 4;
    if (cpos == std::string::npos || cpos - pos > 64) continue;
    const double r =
        std::strtod(text.c_str() + pos + (text[pos] == ':' || text[pos] == '>'), nullptr);
    const double c = std::strtod(
        text.c_str() + cpos + 4 + (text[cpos + 4] == ':' || text[cpos + 4] == '>'), nullptr);
    if (r * c > static_cast<double>(size)) {
      const int l = 1 + static_cast<int>(std::count(text.begin(), text.begin() + cpos, '\n'));
      fail(l, StrCat("matrix of ", r, " x ", c, " elements exceeds what the file's ", size,
                     " bytes can hold"));
    }
  }
}

OpenCvCalibration ReadOpenCvKeySpellings(const std::vector<fs::path>& paths, int camera_width,
                                         int camera_height, int projector_width,
                                         int projector_height) {
  if (paths.empty()) throw Error("no OpenCV calibration file given");
  const Files files(paths);
  OpenCvCalibration out;
  out.format = "opencv";
  auto note = [&](const std::optional<Found>& f, const char* what) {
    if (f) out.keys_used.push_back(StrCat(Where(*f), " -> ", what));
  };
  const auto lk = files.Matrix(kLeftK, "left camera matrix");
  const auto ld = files.Matrix(kLeftD, "left distortion");
  const auto rk = files.Matrix(kRightK, "right camera matrix");
  const auto rd = files.Matrix(kRightD, "right distortion");
  const auto pk = files.Matrix(kProjK, "projector matrix");
  const auto pd = files.Matrix(kProjD, "projector distortion");
  const auto rr = files.Matrix(kRightR, "right_from_left rotation");
  const auto rt = files.Matrix(kRightT, "right_from_left translation");
  const auto pr = files.Matrix(kProjR, "projector_from_left rotation");
  const auto pt = files.Matrix(kProjT, "projector_from_left translation");
  const std::string names = [&] {
    std::string s;
    for (const auto& p : paths) s += (s.empty() ? "" : ", ") + p.string();
    return s;
  }();
  if (!lk) {
    throw Error(StrCat(names, ": no camera matrix found (looked for ", kLeftK[0], ", ", kLeftK[1],
                       ", ", kLeftK[2], ", ... ; docs/formats.md lists the spellings)"));
  }
  std::string size_source;
  auto [w, h] = files.Size({{"image_width", "image_height"},
                            {"imageWidth", "imageHeight"},
                            {"width", "height"},
                            {"camera_width", "camera_height"}},
                           {"imageSize", "image_size", "img_size", "imgSize", "S"}, &size_source);
  if (w > 0 && h > 0) {
    out.keys_used.push_back(StrCat(size_source, " -> camera image size ", w, "x", h));
  } else {
    w = camera_width;
    h = camera_height;
    if (w < 0 && lk->m.cols == 9) {
      // Description only (fringe info): twice the principal point stands in for the size.
      w = std::max(1, static_cast<int>(std::lround(2 * lk->m.at<double>(2))));
      h = std::max(1, static_cast<int>(std::lround(2 * lk->m.at<double>(5))));
      out.keys_used.push_back(StrCat("image size not in the file; assumed ", w, "x", h,
                                     " (twice the principal point) for this description"));
    } else if (w <= 0 || h <= 0) {
      throw Error(StrCat(names,
                         ": the camera image size is not in the file (image_width/"
                         "image_height or imageSize) and was not given"));
    }
    if (camera_width > 0) {
      out.keys_used.push_back(StrCat("camera image size ", w, "x", h, " given (not in the file)"));
    }
  }
  util::CheckRange(w, 1, util::kMaxImageSidePx, names, "camera image width");
  util::CheckRange(h, 1, util::kMaxImageSidePx, names, "camera image height");
  note(lk, "left camera matrix");
  note(ld, "left distortion");
  out.left = Camera(*lk, ld, w, h, "left");
  if (rk) {
    note(rk, "right camera matrix");
    note(rd, "right distortion");
    out.right = Camera(*rk, rd, w, h, "right");
  } else if (rd) {
    throw Error(StrCat(Where(*rd), ": right distortion without a right camera matrix"));
  }
  if (pk) {
    std::string psource;
    auto [pw, ph] = files.Size({{"projector_width", "projector_height"},
                                {"projectorWidth", "projectorHeight"},
                                {"proj_width", "proj_height"}},
                               {"projectorSize", "projector_size", "projSize"}, &psource);
    if (!(pw > 0 && ph > 0) && projector_width > 0 && projector_height > 0) {
      pw = projector_width;
      ph = projector_height;
      psource = "given (not in the file)";
    }
    if (pw > 0 && ph > 0) {
      util::CheckRange(pw, 1, util::kMaxImageSidePx, names, "projector width");
      util::CheckRange(ph, 1, util::kMaxImageSidePx, names, "projector height");
      note(pk, "projector matrix");
      note(pd, "projector distortion");
      out.keys_used.push_back(StrCat(psource, " -> projector size ", pw, "x", ph));
      out.projector = Camera(*pk, pd, pw, ph, "projector");
    } else {
      out.keys_used.push_back(StrCat(Where(*pk),
                                     ": projector ignored (its size is not in the file: "
                                     "projector_width/projector_height or projectorSize)"));
    }
  }
  // R/T describe the second device: the right camera, or the projector when the file has one
  // camera and a projector (camera-projector systems).
  if (rr || rt) {
    if (!rr || !rt) {
      throw Error(StrCat(Where(rr ? *rr : *rt), ": rotation and translation come in pairs"));
    }
    if (out.right || !pk) {
      out.right_from_left = Extrinsics(*rr, *rt, "right_from_left");
      note(rr, "right_from_left rotation");
      note(rt, "right_from_left translation (mm)");
    } else if (out.projector && !pr) {
      out.projector_from_left = Extrinsics(*rr, *rt, "projector_from_left");
      note(rr, "projector_from_left rotation");
      note(rt, "projector_from_left translation (mm)");
    }
  }
  if (pr || pt) {
    if (!pr || !pt) {
      throw Error(StrCat(Where(pr ? *pr : *pt), ": rotation and translation come in pairs"));
    }
    if (out.projector) {
      out.projector_from_left = Extrinsics(*pr, *pt, "projector_from_left");
      note(pr, "projector_from_left rotation");
      note(pt, "projector_from_left translation (mm)");
    }
  }
  if (out.projector && !out.projector_from_left) {
    out.keys_used.push_back("projector ignored: no projector extrinsics (Rlp/Tlp or similar)");
    out.projector.reset();
  }
  return out;
}

CameraModel CameraFromMatrices(const std::vector<double>& k, const std::vector<double>* d,
                               int width, int height, const std::string& device,
                               const std::string& k_where, const std::string& d_where) {
  if (k.size() != 9) {
    throw Error(StrCat(k_where, " (", device, " camera matrix): ", k.size(),
                       " entries, expected a 3x3 matrix"));
  }
  const double* a = k.data();
  if (a[1] != 0 || a[3] != 0 || a[6] != 0 || a[7] != 0 || a[8] != 1) {
    // Skew or a scaled matrix: fringe's model has neither.
    throw Error(StrCat(k_where, " (", device,
                       " camera matrix): expected [fx 0 cx; 0 fy cy; 0 0 1] (no skew)"));
  }
  CameraModel c;
  c.width = width;
  c.height = height;
  c.fx = a[0];
  c.cx = a[2];
  c.fy = a[4];
  c.cy = a[5];
  std::array<double, 5> dist{0, 0, 0, 0, 0};
  if (d) {
    const int n = static_cast<int>(d->size());
    if (n != 4 && n != 5 && n != 8 && n != 12 && n != 14) {
      throw Error(StrCat(d_where, " (", device, " distortion): ", n,
                         " coefficients; expected 4 or 5 (k1 k2 p1 p2 [k3])"));
    }
    for (int i = 5; i < n; ++i) {
      if ((*d)[i] != 0) {
        throw Error(StrCat(d_where, " (", device, " distortion): ", n,
                           " coefficients (OpenCV's rational / thin-prism / tilt model); fringe's "
                           "model is k1 k2 p1 p2 k3 and coefficient ",
                           i, " is ", (*d)[i],
                           ", not 0: recalibrate with the 5-coefficient model"));
      }
    }
    for (int i = 0; i < std::min(n, 5); ++i) dist[i] = (*d)[i];
  }
  c.SetDistortion(dist);
  try {
    c.Check();
  } catch (const Error& e) {
    throw Error(StrCat(k_where, " (", device, " camera): ", e.what()));
  }
  CheckPlausibleCamera(c, StrCat(k_where, " (", device, " camera)"));
  return c;
}

Rigid3d RigidFromMatrices(const std::vector<double>& r, const std::vector<double>& t,
                          double mm_per_unit, const std::string& what, const std::string& r_where,
                          const std::string& t_where) {
  Eigen::Matrix3d m;
  if (r.size() == 9) {
    for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = r[i];
  } else if (r.size() == 3) {
    // A Rodrigues vector (as cv::stereoCalibrate's callers sometimes save om).
    const Eigen::Vector3d om(r[0], r[1], r[2]);
    const double angle = om.norm();
    m = angle > 0 ? Eigen::AngleAxisd(angle, om / angle).toRotationMatrix()
                  : Eigen::Matrix3d::Identity();
  } else {
    throw Error(StrCat(r_where, " (", what, " rotation): ", r.size(),
                       " entries, expected a 3x3 matrix or a 3-vector"));
  }
  CheckRotationMatrix(m, StrCat(r_where, " (", what, " rotation)"));
  if (t.size() != 3) {
    throw Error(StrCat(t_where, " (", what, " translation): ", t.size(), " entries, expected 3"));
  }
  return Rigid3d(m, mm_per_unit * Eigen::Vector3d(t[0], t[1], t[2]));
}

namespace {

// The devices read, for the error messages of ToRig / ToCameraProjectorRig.
std::string Holdings(const OpenCvCalibration& c) {
  std::string have = c.left ? "left camera" : "";
  if (c.right) have += ", right camera";
  if (c.projector) have += ", projector";
  return have.empty() ? "nothing usable" : have;
}

}  // namespace

StereoRig OpenCvCalibration::ToRig(const std::string& context) const {
  if (!left || !right || !right_from_left) {
    throw Error(StrCat(context,
                       ": fringe reconstructs with two cameras and their extrinsics "
                       "(R/T); the file holds: ",
                       Holdings(*this)));
  }
  StereoRig rig;
  rig.left = *left;
  rig.right = *right;
  rig.right_from_left = *right_from_left;
  if (projector && projector_from_left) {
    rig.projector = *projector;
    rig.projector_from_left = *projector_from_left;
  }
  return rig;
}

StereoRig OpenCvCalibration::ToCameraProjectorRig(const std::string& context) const {
  if (!left || !projector || !projector_from_left) {
    throw Error(StrCat(context,
                       ": camera-projector mode needs a camera, the projector (with its size) and "
                       "their extrinsics (Rlp/Tlp or similar); the file holds: ",
                       Holdings(*this)));
  }
  StereoRig rig;
  rig.left = *left;
  rig.right = right ? *right : *left;
  if (right && right_from_left) rig.right_from_left = *right_from_left;
  rig.projector = *projector;
  rig.projector_from_left = *projector_from_left;
  return rig;
}

std::string OpenCvCalibration::Describe() const {
  std::ostringstream os;
  if (!format.empty()) os << "  format: " << format << "\n";
  os << "  devices:";
  if (left) os << " left camera";
  if (right) os << ", right camera";
  if (projector) os << ", projector";
  os << "\n";
  for (const auto& k : keys_used) os << "  " << k << "\n";
  if (right_from_left) {
    os << "  baseline " << right_from_left->translation().norm() << " (file units, taken as mm)\n";
  }
  return os.str();
}

}  // namespace fringe::io
