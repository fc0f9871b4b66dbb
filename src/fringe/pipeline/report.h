// The scan report: one self-contained HTML page (images embedded as base64 PNG data URIs, no
// external URL, no script) with the pictures of a scan and all its figures as tables, and the
// picture helpers the pipeline fills it with: false-colour maps of per-pixel values with a
// colour bar legend in their unit, and shaded renderings of a triangle mesh cast with Embree
// (sim::RayCaster, the virtual scanner's ray caster).
//
// Thread safety: plain values; the free functions have no shared state.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace fringe::pipeline {

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

// Lambert-shaded rendering of a triangle mesh seen from `view_dir` (unit vector from the eye
// toward the mesh, world frame), orthographic, fitted to the mesh's bounding sphere, on a
// width_px x height_px image (CV_8UC1; background black). Embree ray casting.
cv::Mat RenderMesh(const std::vector<Eigen::Vector3d>& vertices,
                   const std::vector<std::array<int32_t, 3>>& triangles,
                   const Eigen::Vector3d& view_dir, int width_px = 480, int height_px = 360);

}  // namespace fringe::pipeline
