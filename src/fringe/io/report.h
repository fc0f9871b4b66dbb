// The pieces of a self-contained report page (one HTML file, images embedded as base64 PNG data
// URIs, no external URL, no script): sections of text, tables and pictures, and the picture
// helpers that fill them: false-colour maps of per-pixel values with a colour bar legend in
// their unit, and histograms. The scan report (pipeline/report.h, which adds renderings of
// meshes), the calibration report (calib/diagnostics.h) and the check page (eval/check.h) are
// built from them.
//
// Thread safety: plain values; the free functions have no shared state.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
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

struct ReportSection {
  std::string title;
  std::vector<std::string> paragraphs;  // plain text (escaped when rendered)
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

// The colour bar ColourMapWithBar puts under its map: a turbo gradient from lo to hi, five
// labelled ticks and `unit` below, width_px wide (CV_8UC3, white background).
cv::Mat ColourBar(int width_px, double lo, double hi, const std::string& unit);

// Histogram of `values` in [lo, hi] (values outside are counted in the end bins and the counts
// noted), `bins` bars, x axis labelled `unit`, a vertical marker line at each of `marks` (e.g.
// a threshold); CV_8UC3 on white, width_px x height_px.
cv::Mat HistogramImage(const std::vector<double>& values, double lo, double hi, int bins,
                       const std::string& unit, const std::vector<double>& marks = {},
                       int width_px = 420, int height_px = 220);

}  // namespace fringe::io
