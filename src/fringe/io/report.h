// The pieces of a self-contained report page (one HTML file, images embedded as base64 PNG or JPEG
// data URIs, no external URL): sections of text, tables, pictures and an interactive 3D view, and
// the picture helpers that fill them: false-colour maps of per-pixel values with a colour bar
// legend in their unit, and histograms. A page with a 3D view carries its one script, the bundled
// viewer of web/viewer/ (three.js, WebGL), embedded into this library at build time. The scan
// report (pipeline/report.h, which adds renderings of meshes), the calibration report
// (calib/diagnostics.h) and the check page (eval/check.h) are built from them.
//
// Thread safety: plain values; the free functions have no shared state.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace fringe::io {

struct ReportImage {
  std::string caption;
  cv::Mat image;  // CV_8UC1 or CV_8UC3 (BGR)
};

struct ReportTable {
  std::string caption;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

// An interactive 3D view (docs/formats.md, "The report's 3D view"): a JSON description of what
// to draw (mesh, points, colourings, markers, sensors, boards) whose big arrays are binary,
// little-endian, in one block embedded as base64 (description["arrays"] names each: its type,
// byte offset and count). Without WebGL or JavaScript the page says why the view is missing;
// its pictures stand in.
class ReportScene {
 public:
  nlohmann::json description = nlohmann::json::object();

  // Appends `values` to the block (aligned to 4 bytes) and names them `name` in
  // description["arrays"]. Throws fringe::Error for a name given twice.
  void AddArray(const std::string& name, const std::vector<float>& values);
  void AddArray(const std::string& name, const std::vector<uint32_t>& values);
  void AddArray(const std::string& name, const std::vector<uint16_t>& values);
  void AddArray(const std::string& name, const std::vector<uint8_t>& values);
  const std::vector<uint8_t>& bytes() const { return bytes_; }

 private:
  template <typename T>
  void Add(const std::string& name, const char* type, const std::vector<T>& values);
  std::vector<uint8_t> bytes_;
};

struct ReportSection {
  std::string title;
  std::vector<std::string> paragraphs;  // plain text (escaped when rendered)
  std::optional<ReportScene> scene;     // drawn after the paragraphs
  std::vector<ReportTable> tables;
  std::vector<ReportImage> images;
};

struct Report {
  std::string title;
  std::vector<ReportSection> sections;

  // The page. Throws fringe::Error when an image cannot be encoded.
  std::string ToHtml() const;
  // Writes ToHtml() to `path` atomically.
  void Write(const std::filesystem::path& path) const;
};

// Standard base64 (RFC 4648, with padding).
std::string Base64(const std::vector<uint8_t>& bytes);

// False-colour picture of a CV_32F map (turbo colour map: lo blue ... hi red), NaN drawn dark
// grey, with a colour bar below labelled in `unit` from lo to hi. The map is shrunk to at most
// max_width_px wide (area averaging of the finite values).
cv::Mat ColourMapWithBar(const cv::Mat& values, double lo, double hi, const std::string& unit,
                         int max_width_px = 640);
// Robust display range: the p and 1 - p quantiles of the finite values (lo == hi widened by 1).
std::array<double, 2> DisplayRange(const cv::Mat& values, double p = 0.01);

// The colour range of a signed deviation (mm): symmetric, -half_range_mm to +half_range_mm, so
// that zero is the middle colour. From the data, a high percentile of |deviation| (the bulk of
// the measurement fills the colour map, the worst few percent saturate), or a tolerance the user
// gives (`--tolerance MM`, as inspection software colours its +-tolerance band). Every picture
// and the 3D view of one report use the same range, and the colour bar says which (Legend).
// The 95th percentile by default: a scan's worst few percent (the rounded edges of a mesh: on the
// demo's mesh |deviation| has its median at 0.007 mm, 95th percentile 0.100, 99th 0.316 mm)
// would otherwise stretch the range until the whole measured surface is one colour.
struct DeviationRange {
  double half_range_mm = 1;
  bool from_tolerance = false;  // else from the data
  double percentile = 95;       // from the data: the percentile of |deviation| taken

  // The `percentile` (in (0, 100], nearest rank) of the finite |values|; 1e-3 mm at least (all
  // zero, or no finite value: the range must not be empty).
  static DeviationRange FromData(const std::vector<double>& values, double percentile = 95);
  // Throws fringe::Error unless tolerance_mm > 0 and finite.
  static DeviationRange FromTolerance(double tolerance_mm);
  double lo() const { return -half_range_mm; }
  double hi() const { return half_range_mm; }
  // `what` with the range and where it comes from, for the colour bar: e.g. "signed deviation
  // from truth, mm (+-0.1: 95th percentile of |deviation|)".
  std::string Legend(const std::string& what) const;
};

// The colour bar ColourMapWithBar puts under its map: a turbo gradient from lo to hi, five
// labelled ticks (three when narrower than 400 px) and `unit` below (on two lines, split before
// its last " (", when one is too wide), width_px wide (CV_8UC3, white background).
cv::Mat ColourBar(int width_px, double lo, double hi, const std::string& unit);

// Histogram of `values` in [lo, hi] (values outside are counted in the end bins and the counts
// noted), `bins` bars, x axis labelled `unit`, a vertical marker line at each of `marks` (e.g.
// a threshold); CV_8UC3 on white, width_px x height_px.
cv::Mat HistogramImage(const std::vector<double>& values, double lo, double hi, int bins,
                       const std::string& unit, const std::vector<double>& marks = {},
                       int width_px = 420, int height_px = 220);

}  // namespace fringe::io
