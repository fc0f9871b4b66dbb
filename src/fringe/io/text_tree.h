// Untrusted YAML and XML calibration files as one small tree, read with explicit limits.
//
// Other tools' calibration files come as YAML (ROS camera_info, Kalibr camchain, OpenCV's
// "%YAML:1.0" files) or XML (OpenCV's <opencv_storage>, e.g. SLStudio's calibration.xml). They
// are parsed by yaml-cpp and tinyxml2 (libraries written for untrusted input, unlike
// cv::FileStorage) and copied into a TextNode tree that the calibration readers walk, so every
// reader sees the same node kinds whatever the syntax:
//   YAML mapping / sequence / scalar       -> kMap / kSeq / kScalar (null -> kNull)
//   XML element with child elements        -> kMap (children by tag, in file order)
//   XML element with text only             -> kScalar; inside an element with
//     type_id="opencv-matrix", <data> text -> kSeq of its whitespace-separated numbers
// Limits (TextTreeLimits), checked before anything is allocated from the file's declarations:
// file size, nesting depth, total node count (a YAML alias bomb expands in the copy and hits it),
// scalar length. Every failure is a fringe::Error naming the file and, where known, the line.
//
// Thread safety: pure functions.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace fringe::io {

struct TextTreeLimits {
  std::uintmax_t max_bytes = std::uintmax_t{4} << 20;  // calibration files are a few kB
  int max_depth = 32;                                  // nesting of maps / sequences / elements
  int64_t max_nodes = 100000;                          // nodes after alias expansion
  size_t max_scalar_bytes = 4096;                      // one value (a number, a name)
};

struct TextNode {
  enum class Kind { kNull, kScalar, kSeq, kMap };
  Kind kind = Kind::kNull;
  std::string scalar;                                    // kScalar
  std::vector<TextNode> items;                           // kSeq
  std::vector<std::pair<std::string, TextNode>> fields;  // kMap, in file order
  int line = 0;                                          // 1-based, 0 when unknown

  bool IsMap() const { return kind == Kind::kMap; }
  bool IsSeq() const { return kind == Kind::kSeq; }
  bool IsScalar() const { return kind == Kind::kScalar; }
  // The field `key` of a map (first occurrence), or nullptr.
  const TextNode* Find(const std::string& key) const;
  // The scalar as a finite double / an integer, or nullopt when it is not one.
  std::optional<double> Number() const;
  std::optional<long long> Integer() const;
};

struct TextTree {
  std::filesystem::path path;
  bool xml = false;
  // Written by cv::FileStorage: "%YAML:1.0" / "%YAML 1.0" first line or an <opencv_storage> root.
  bool opencv_header = false;
  TextNode root;  // kMap for every calibration file (an XML root's children)
};

// Parses `path` (XML when the first non-blank byte is '<', else YAML). Throws fringe::Error
// naming the file: missing, too large, not parseable, over a limit, or a top level that is not a
// mapping; a key given twice in one mapping is an error naming it (tools never write that, and
// taking either copy would calibrate with a value the user did not mean).
TextTree ReadTextTree(const std::filesystem::path& path, const TextTreeLimits& limits = {});

// A matrix held by `node`, row-major: an OpenCV / ROS matrix map {rows, cols, data} (rows x cols
// must equal the data count, each side in [1, 64]), a flat sequence of numbers, or a sequence of
// equally long number sequences (Kalibr's T_cn_cnm1). nullopt when the node is none of these;
// *why (when given) then says what is wrong when the node looked like a matrix.
struct TextMatrix {
  int rows = 0, cols = 0;
  std::vector<double> data;  // rows * cols values, row-major, all finite
};
std::optional<TextMatrix> ToMatrix(const TextNode& node, std::string* why = nullptr);

}  // namespace fringe::io
