#include "fringe/pipeline/report.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "fringe/sim/ray_caster.h"
#include "fringe/sim/scene.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::pipeline {
namespace {

std::string EscapeHtml(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string PngDataUri(const cv::Mat& image, const std::string& caption) {
  std::vector<uint8_t> png;
  if (image.empty() || !cv::imencode(".png", image, png)) {
    throw Error(util::StrCat("report: cannot encode the picture '", caption, "' as PNG"));
  }
  return "data:image/png;base64," + Base64(png);
}

std::string FormatTick(double v) {
  std::ostringstream os;
  const double a = std::abs(v);
  os << std::setprecision(a != 0 && (a < 0.01 || a >= 1e5) ? 2 : 4) << v;
  return os.str();
}

}  // namespace

std::string Base64(const std::vector<uint8_t>& bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = (uint32_t(bytes[i]) << 16) | (uint32_t(bytes[i + 1]) << 8) | bytes[i + 2];
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const uint32_t v = uint32_t(bytes[i]) << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const uint32_t v = (uint32_t(bytes[i]) << 16) | (uint32_t(bytes[i + 1]) << 8);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

std::array<double, 2> DisplayRange(const cv::Mat& values, double p) {
  CV_Assert(values.type() == CV_32F);
  std::vector<float> finite;
  finite.reserve(values.total());
  for (int r = 0; r < values.rows; ++r) {
    const float* row = values.ptr<float>(r);
    for (int c = 0; c < values.cols; ++c) {
      if (std::isfinite(row[c])) finite.push_back(row[c]);
    }
  }
  if (finite.empty()) return {0.0, 1.0};
  auto quantile = [&](double q) {
    const size_t k = std::min(finite.size() - 1, static_cast<size_t>(q * (finite.size() - 1)));
    std::nth_element(finite.begin(), finite.begin() + static_cast<std::ptrdiff_t>(k), finite.end());
    return static_cast<double>(finite[k]);
  };
  double lo = quantile(p), hi = quantile(1 - p);
  if (!(hi > lo)) {
    lo -= 0.5;
    hi += 0.5;
  }
  return {lo, hi};
}

cv::Mat ColourMapWithBar(const cv::Mat& values, double lo, double hi, const std::string& unit,
                         int max_width_px) {
  CV_Assert(values.type() == CV_32F && !values.empty() && hi > lo && max_width_px > 0);
  // Shrink by area averaging over the finite values only (NaN must not bleed into neighbours).
  cv::Mat finite_mask(values.size(), CV_32F), filled(values.size(), CV_32F);
  for (int r = 0; r < values.rows; ++r) {
    for (int c = 0; c < values.cols; ++c) {
      const float v = values.at<float>(r, c);
      const bool ok = std::isfinite(v);
      finite_mask.at<float>(r, c) = ok ? 1.f : 0.f;
      filled.at<float>(r, c) = ok ? v : 0.f;
    }
  }
  cv::Mat small = filled, small_mask = finite_mask;
  if (values.cols > max_width_px) {
    const cv::Size size(
        max_width_px, std::max(1, static_cast<int>(std::lround(double(values.rows) * max_width_px /
                                                               values.cols))));
    cv::resize(filled, small, size, 0, 0, cv::INTER_AREA);
    cv::resize(finite_mask, small_mask, size, 0, 0, cv::INTER_AREA);
  }
  cv::Mat grey(small.size(), CV_8U);
  for (int r = 0; r < small.rows; ++r) {
    for (int c = 0; c < small.cols; ++c) {
      const float m = small_mask.at<float>(r, c);
      const double v = m > 0.5f ? small.at<float>(r, c) / m : 0.0;
      grey.at<uint8_t>(r, c) =
          static_cast<uint8_t>(std::clamp((v - lo) / (hi - lo), 0.0, 1.0) * 255);
    }
  }
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  for (int r = 0; r < small.rows; ++r) {
    for (int c = 0; c < small.cols; ++c) {
      if (small_mask.at<float>(r, c) <= 0.5f) colour.at<cv::Vec3b>(r, c) = cv::Vec3b(48, 48, 48);
    }
  }
  // Colour bar: a gradient strip and five labelled ticks, white background.
  const int width = colour.cols, margin = 12, strip_h = 14, bar_h = 52;
  cv::Mat bar(bar_h, width, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::Mat ramp(1, width - 2 * margin, CV_8U);
  for (int c = 0; c < ramp.cols; ++c) {
    ramp.at<uint8_t>(0, c) = static_cast<uint8_t>(255.0 * c / std::max(1, ramp.cols - 1));
  }
  cv::Mat ramp_colour;
  cv::applyColorMap(ramp, ramp_colour, cv::COLORMAP_TURBO);
  cv::resize(ramp_colour, ramp_colour, cv::Size(ramp.cols, strip_h), 0, 0, cv::INTER_NEAREST);
  ramp_colour.copyTo(bar(cv::Rect(margin, 4, ramp.cols, strip_h)));
  const double font = 0.4;
  for (int k = 0; k <= 4; ++k) {
    const int x = margin + static_cast<int>(std::lround(k * (ramp.cols - 1) / 4.0));
    cv::line(bar, {x, 4 + strip_h}, {x, 4 + strip_h + 4}, cv::Scalar(0, 0, 0));
    const std::string label = FormatTick(lo + (hi - lo) * k / 4.0);
    int baseline = 0;
    const cv::Size ts = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, font, 1, &baseline);
    const int tx = std::clamp(x - ts.width / 2, 0, std::max(0, width - ts.width));
    cv::putText(bar, label, {tx, 4 + strip_h + 6 + ts.height}, cv::FONT_HERSHEY_SIMPLEX, font,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  int baseline = 0;
  const cv::Size us = cv::getTextSize(unit, cv::FONT_HERSHEY_SIMPLEX, font, 1, &baseline);
  cv::putText(bar, unit, {std::max(0, (width - us.width) / 2), bar_h - 4}, cv::FONT_HERSHEY_SIMPLEX,
              font, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  cv::Mat out;
  cv::vconcat(colour, bar, out);
  return out;
}

cv::Mat RenderMesh(const std::vector<Eigen::Vector3d>& vertices,
                   const std::vector<std::array<int32_t, 3>>& triangles,
                   const Eigen::Vector3d& view_dir, int width_px, int height_px) {
  CV_Assert(width_px > 0 && height_px > 0);
  cv::Mat image(height_px, width_px, CV_8U, cv::Scalar(0));
  if (vertices.empty() || triangles.empty()) return image;
  sim::SceneObject object;
  object.name = "mesh";
  object.mesh.vertices = vertices;
  object.mesh.triangles = triangles;
  sim::Scene scene;
  scene.AddObject(std::move(object));
  const sim::RayCaster caster(scene);
  Eigen::Vector3d lo, hi;
  scene.Bounds(&lo, &hi);
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double radius = std::max(1e-9, 0.5 * (hi - lo).norm());
  // Camera frame: d forward, u right, v down (image rows), with world z up on the picture
  // unless the view looks along z.
  const Eigen::Vector3d d = view_dir.normalized();
  const Eigen::Vector3d up =
      std::abs(d.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d u = d.cross(up).normalized();
  const Eigen::Vector3d v = d.cross(u).normalized();
  const double scale = 2.1 * radius / std::min(width_px, height_px);  // mm per pixel
  // Light from over the viewer's left shoulder, so relief reads naturally.
  const Eigen::Vector3d to_light = (-d - 0.5 * u - 0.5 * v).normalized();
  for (int r = 0; r < height_px; ++r) {
    for (int c = 0; c < width_px; ++c) {
      const Eigen::Vector3d origin = centre - 2 * radius * d +
                                     (c - 0.5 * (width_px - 1)) * scale * u +
                                     (r - 0.5 * (height_px - 1)) * scale * v;
      const auto hit = caster.Cast(origin, d);
      if (!hit) continue;
      Eigen::Vector3d n = hit->normal;
      if (n.dot(d) > 0) n = -n;  // both faces lit: open meshes show their inside as well
      const double shade = 0.15 + 0.85 * std::max(0.0, n.dot(to_light));
      image.at<uint8_t>(r, c) = static_cast<uint8_t>(std::lround(40 + 215 * shade));
    }
  }
  return image;
}

std::string Report::ToHtml() const {
  std::ostringstream os;
  os << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>"
     << EscapeHtml(title) << "</title>\n<style>\n"
     << "body{font-family:sans-serif;margin:1.5em;color:#222;max-width:1400px}\n"
     << "h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;margin-top:1.6em}\n"
     << "table{border-collapse:collapse;margin:.6em 0}td,th{border:1px solid #ccc;"
        "padding:2px 8px;text-align:right;font-size:.9em}th{background:#f0f0f0}\n"
     << "td:first-child,th:first-child{text-align:left}caption{text-align:left;"
        "font-weight:bold;padding:2px 0}\n"
     << "figure{display:inline-block;margin:.4em;vertical-align:top}"
        "figcaption{font-size:.85em;max-width:640px}\n"
     << "</style></head><body>\n<h1>" << EscapeHtml(title) << "</h1>\n";
  for (const ReportSection& s : sections) {
    os << "<h2>" << EscapeHtml(s.title) << "</h2>\n";
    for (const std::string& p : s.paragraphs) os << "<p>" << EscapeHtml(p) << "</p>\n";
    for (const ReportTable& t : s.tables) {
      os << "<table>";
      if (!t.caption.empty()) os << "<caption>" << EscapeHtml(t.caption) << "</caption>";
      os << "\n<tr>";
      for (const std::string& h : t.header) os << "<th>" << EscapeHtml(h) << "</th>";
      os << "</tr>\n";
      for (const auto& row : t.rows) {
        os << "<tr>";
        for (const std::string& cell : row) os << "<td>" << EscapeHtml(cell) << "</td>";
        os << "</tr>\n";
      }
      os << "</table>\n";
    }
    for (const ReportImage& im : s.images) {
      os << "<figure><img src=\"" << PngDataUri(im.image, im.caption) << "\" alt=\""
         << EscapeHtml(im.caption) << "\" width=\"" << im.image.cols << "\" height=\""
         << im.image.rows << "\"><figcaption>" << EscapeHtml(im.caption)
         << "</figcaption></figure>\n";
    }
  }
  os << "</body></html>\n";
  return os.str();
}

void Report::Write(const std::filesystem::path& path) const {
  const std::string html = ToHtml();
  util::WriteAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << html;
    out.flush();
    if (!out) throw Error(util::StrCat(path.string(), ": cannot write the report"));
  });
}

}  // namespace fringe::pipeline
