#include "fringe/io/report.h"

#include <tbb/parallel_for.h>
#include <zlib.h>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace internal {
// web/viewer/dist/viewer.js (the generated viewer_script.cc, src/fringe/io/CMakeLists.txt).
extern const unsigned char kViewerScript[];
extern const std::size_t kViewerScriptSize;
}  // namespace internal
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

// A picture as a data URI: PNG (lossless), or JPEG at kJpegQuality when that is at most half the
// PNG's size. The pictures of measured data (phase, modulation, texture, deviation maps) are
// noise-like colour maps that PNG barely compresses (~0.8 MB a view at half size: 9.5 of the
// demo report's 18.8 MB, and the page's load time follows its size); as JPEG they are a
// fraction of that, with differences of a few DN no reader of a picture sees. Plots of flat
// colours and text stay PNG, where JPEG would ring and gain little. The measured values
// themselves are in the output files, not in the pictures.
constexpr int kJpegQuality = 92;
std::string PictureDataUri(const cv::Mat& image, const std::string& caption) {
  std::vector<uint8_t> png, jpeg;
  if (image.empty() || !cv::imencode(".png", image, png)) {
    throw Error(util::StrCat("report: cannot encode the picture '", caption, "' as PNG"));
  }
  if (cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, kJpegQuality}) &&
      2 * jpeg.size() <= png.size()) {
    return "data:image/jpeg;base64," + Base64(jpeg);
  }
  return "data:image/png;base64," + Base64(png);
}

// The scene's arrays compressed by zlib (RFC 1950, what the browsers' DecompressionStream
// ('deflate') reads): the demo's 6.5 MB of arrays become 3.3 MB. Level 1 (Z_BEST_SPEED): on the
// full rig's 6.9 MB of arrays it gave 3.98 MB in 0.12 s, level 6 (the default) 3.99 MB in 0.32 s.
std::vector<uint8_t> Deflate(const std::vector<uint8_t>& bytes) {
  uLongf size = compressBound(static_cast<uLong>(bytes.size()));
  std::vector<uint8_t> out(size);
  if (compress2(out.data(), &size, bytes.data(), static_cast<uLong>(bytes.size()), Z_BEST_SPEED) !=
      Z_OK) {
    throw Error("report: cannot compress the 3D view's arrays");
  }
  out.resize(size);
  return out;
}

std::string FormatTick(double v) {
  std::ostringstream os;
  const double a = std::abs(v);
  os << std::setprecision(a != 0 && (a < 0.01 || a >= 1e5) ? 2 : 4) << v;
  return os.str();
}

// JSON inside <script type="application/json">: no "</script" nor "<!--" may appear, so every
// '<' (only ever inside a string) is written as its escape.
std::string JsonForScript(const nlohmann::json& j) {
  const std::string text = j.dump();
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    if (c == '<') {
      out += "\\u003c";
    } else {
      out += c;
    }
  }
  return out;
}

// `arrays`: the scene's bytes deflated and in base64 (SceneArrays).
void WriteScene(std::ostream& os, const ReportScene& scene, const std::string& arrays, int index) {
  const std::string id = util::StrCat("fringe-scene-", index);
  os << "<div class=\"fringe-scene\" id=\"" << id << "\"><p class=\"fv-message\">"
     << "The interactive 3D view needs JavaScript and WebGL; the pictures below show the model."
     << "</p></div>\n<script type=\"application/json\" id=\"" << id << "-description\">"
     << JsonForScript(scene.description)
     << "</script>\n<script type=\"application/octet-stream\" data-encoding=\"deflate\" "
     << "data-bytes=\"" << scene.bytes().size() << "\" id=\"" << id << "-arrays\">" << arrays
     << "</script>\n";
}

std::string SceneArrays(const ReportScene& scene) { return Base64(Deflate(scene.bytes())); }

}  // namespace

template <typename T>
void ReportScene::Add(const std::string& name, const char* type, const std::vector<T>& values) {
  nlohmann::json& arrays = description["arrays"];
  if (arrays.contains(name)) throw Error("report scene: array " + name + " added twice");
  bytes_.resize((bytes_.size() + 3) / 4 * 4, 0);
  const size_t offset = bytes_.size();
  bytes_.resize(offset + values.size() * sizeof(T));
  // Little-endian, as every machine fringe builds on (x86-64, arm64) stores them.
  static_assert(sizeof(T) <= 4);
  if (!values.empty())
    std::memcpy(bytes_.data() + offset, values.data(), values.size() * sizeof(T));
  arrays[name] = {{"type", type}, {"offset", offset}, {"count", values.size()}};
}

void ReportScene::AddArray(const std::string& name, const std::vector<float>& values) {
  Add(name, "float32", values);
}
void ReportScene::AddArray(const std::string& name, const std::vector<uint32_t>& values) {
  Add(name, "uint32", values);
}
void ReportScene::AddArray(const std::string& name, const std::vector<uint16_t>& values) {
  Add(name, "uint16", values);
}
void ReportScene::AddArray(const std::string& name, const std::vector<uint8_t>& values) {
  Add(name, "uint8", values);
}

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

DeviationRange DeviationRange::FromData(const std::vector<double>& values, double percentile) {
  if (!(percentile > 0 && percentile <= 100)) {
    throw Error(util::StrCat("DeviationRange: percentile ", percentile, " must be in (0, 100]"));
  }
  std::vector<double> a;
  a.reserve(values.size());
  for (double v : values) {
    if (std::isfinite(v)) a.push_back(std::abs(v));
  }
  DeviationRange r;
  r.percentile = percentile;
  r.half_range_mm = 1e-3;
  if (a.empty()) return r;
  // The nearest rank (ceil(p n)), so that FromData(values, 100) is the largest.
  const size_t rank = static_cast<size_t>(std::ceil(percentile / 100 * double(a.size())));
  const size_t k = std::clamp<size_t>(rank, 1, a.size()) - 1;
  std::nth_element(a.begin(), a.begin() + static_cast<std::ptrdiff_t>(k), a.end());
  r.half_range_mm = std::max(r.half_range_mm, a[k]);
  return r;
}

DeviationRange DeviationRange::FromTolerance(double tolerance_mm) {
  if (!(std::isfinite(tolerance_mm) && tolerance_mm > 0)) {
    throw Error(util::StrCat("tolerance ", tolerance_mm, " mm must be a positive number"));
  }
  DeviationRange r;
  r.half_range_mm = tolerance_mm;
  r.from_tolerance = true;
  return r;
}

std::string DeviationRange::Legend(const std::string& what) const {
  std::ostringstream os;
  os << what << " (+-" << FormatTick(half_range_mm) << ": ";
  if (from_tolerance) {
    os << "the tolerance given)";
  } else {
    os << FormatTick(percentile) << "th percentile of |deviation|)";
  }
  return os.str();
}

cv::Mat ColourBar(int width_px, double lo, double hi, const std::string& unit) {
  CV_Assert(width_px > 24 && hi > lo);
  const double font = 0.4;
  // The legend on one line, or on two (split before its last " (") when it is wider than the
  // bar; a line still too wide is set smaller.
  std::vector<std::string> lines = {unit};
  int baseline = 0;
  const auto text_width = [&](const std::string& t) {
    return cv::getTextSize(t, cv::FONT_HERSHEY_SIMPLEX, font, 1, &baseline).width;
  };
  if (text_width(unit) > width_px - 4 && unit.rfind(" (") != std::string::npos) {
    const size_t split = unit.rfind(" (");
    lines = {unit.substr(0, split), unit.substr(split + 1)};
  }
  // A gradient strip and labelled ticks (five, three on a narrow bar), white background.
  const int width = width_px, margin = 12, strip_h = 14, line_h = 14;
  const int bar_h = 38 + line_h * static_cast<int>(lines.size());
  cv::Mat bar(bar_h, width, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::Mat ramp(1, width - 2 * margin, CV_8U);
  for (int c = 0; c < ramp.cols; ++c) {
    ramp.at<uint8_t>(0, c) = static_cast<uint8_t>(255.0 * c / std::max(1, ramp.cols - 1));
  }
  cv::Mat ramp_colour;
  cv::applyColorMap(ramp, ramp_colour, cv::COLORMAP_TURBO);
  cv::resize(ramp_colour, ramp_colour, cv::Size(ramp.cols, strip_h), 0, 0, cv::INTER_NEAREST);
  ramp_colour.copyTo(bar(cv::Rect(margin, 4, ramp.cols, strip_h)));
  const int intervals = width_px >= 400 ? 4 : 2;
  for (int k = 0; k <= intervals; ++k) {
    const int x = margin + static_cast<int>(std::lround(k * (ramp.cols - 1) / double(intervals)));
    cv::line(bar, {x, 4 + strip_h}, {x, 4 + strip_h + 4}, cv::Scalar(0, 0, 0));
    const std::string label = FormatTick(lo + (hi - lo) * k / intervals);
    const cv::Size ts = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, font, 1, &baseline);
    const int tx = std::clamp(x - ts.width / 2, 0, std::max(0, width - ts.width));
    cv::putText(bar, label, {tx, 4 + strip_h + 6 + ts.height}, cv::FONT_HERSHEY_SIMPLEX, font,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  for (size_t i = 0; i < lines.size(); ++i) {
    const int w = text_width(lines[i]);
    const double f = w > width - 4 ? std::max(0.28, font * (width - 4) / w) : font;
    const int fw = cv::getTextSize(lines[i], cv::FONT_HERSHEY_SIMPLEX, f, 1, &baseline).width;
    cv::putText(bar, lines[i],
                {std::max(0, (width - fw) / 2),
                 bar_h - 4 - line_h * static_cast<int>(lines.size() - 1 - i)},
                cv::FONT_HERSHEY_SIMPLEX, f, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  return bar;
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
  const cv::Mat bar = ColourBar(colour.cols, lo, hi, unit);
  cv::Mat out;
  cv::vconcat(colour, bar, out);
  return out;
}

cv::Mat HistogramImage(const std::vector<double>& values, double lo, double hi, int bins,
                       const std::string& unit, const std::vector<double>& marks, int width_px,
                       int height_px) {
  CV_Assert(hi > lo && bins >= 1 && width_px > 60 && height_px > 60);
  std::vector<int64_t> count(static_cast<size_t>(bins), 0);
  int64_t below = 0, above = 0, n = 0;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    ++n;
    below += v < lo;
    above += v > hi;
    const int k = static_cast<int>(std::floor((v - lo) / (hi - lo) * bins));
    ++count[static_cast<size_t>(std::clamp(k, 0, bins - 1))];
  }
  cv::Mat img(height_px, width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  const int left = 10, right = width_px - 10, top = 18, bottom = height_px - 36;
  const int64_t peak = std::max<int64_t>(1, *std::max_element(count.begin(), count.end()));
  const double bar_w = double(right - left) / bins;
  for (int k = 0; k < bins; ++k) {
    const int h = static_cast<int>(std::lround(double(count[size_t(k)]) / peak * (bottom - top)));
    const int x0 = left + static_cast<int>(std::lround(k * bar_w));
    const int x1 = left + static_cast<int>(std::lround((k + 1) * bar_w)) - 1;
    if (h > 0) {
      cv::rectangle(img, {x0, bottom - h}, {std::max(x0, x1), bottom}, cv::Scalar(180, 110, 40),
                    cv::FILLED);
    }
  }
  cv::line(img, {left, bottom}, {right, bottom}, cv::Scalar(0, 0, 0));
  for (double m : marks) {
    if (!(m >= lo && m <= hi)) continue;
    const int x = left + static_cast<int>(std::lround((m - lo) / (hi - lo) * (right - left)));
    cv::line(img, {x, top}, {x, bottom}, cv::Scalar(0, 0, 220), 1, cv::LINE_AA);
  }
  const double font = 0.4;
  for (int k = 0; k <= 4; ++k) {
    const int x = left + static_cast<int>(std::lround(k * (right - left) / 4.0));
    cv::line(img, {x, bottom}, {x, bottom + 4}, cv::Scalar(0, 0, 0));
    const std::string label = FormatTick(lo + (hi - lo) * k / 4.0);
    int baseline = 0;
    const cv::Size ts = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, font, 1, &baseline);
    const int tx = std::clamp(x - ts.width / 2, 0, std::max(0, width_px - ts.width));
    cv::putText(img, label, {tx, bottom + 6 + ts.height}, cv::FONT_HERSHEY_SIMPLEX, font,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  const std::string caption = util::StrCat(
      unit, "   (n = ", n, ", peak bin ", peak, below + above > 0 ? ", " : "",
      below + above > 0 ? util::StrCat(below + above, " outside, in the end bins") : std::string(),
      ")");
  cv::putText(img, caption, {left, height_px - 6}, cv::FONT_HERSHEY_SIMPLEX, font,
              cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  return img;
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
  // The encodings first, all at once (the scenes' deflated arrays and every picture's PNG /
  // JPEG are independent; each is the same on any number of threads), then the page in order.
  std::vector<const ReportScene*> scene_list;
  std::vector<const ReportImage*> image_list;
  for (const ReportSection& s : sections) {
    if (s.scene) scene_list.push_back(&*s.scene);
    for (const ReportImage& im : s.images) image_list.push_back(&im);
  }
  std::vector<std::string> scene_arrays(scene_list.size()), image_uris(image_list.size());
  // The scenes first: deflating their arrays is the longest task.
  tbb::parallel_for(size_t{0}, scene_list.size() + image_list.size(), [&](size_t i) {
    if (i < scene_list.size()) {
      scene_arrays[i] = SceneArrays(*scene_list[i]);
    } else {
      const ReportImage& im = *image_list[i - scene_list.size()];
      image_uris[i - scene_list.size()] = PictureDataUri(im.image, im.caption);
    }
  });
  int scenes = 0;
  size_t images = 0;
  for (const ReportSection& s : sections) {
    os << "<h2>" << EscapeHtml(s.title) << "</h2>\n";
    for (const std::string& p : s.paragraphs) os << "<p>" << EscapeHtml(p) << "</p>\n";
    if (s.scene) {
      WriteScene(os, *s.scene, scene_arrays[size_t(scenes)], scenes);
      ++scenes;
    }
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
      os << "<figure><img src=\"" << image_uris[images++] << "\" alt=\"" << EscapeHtml(im.caption)
         << "\" width=\"" << im.image.cols << "\" height=\"" << im.image.rows << "\"><figcaption>"
         << EscapeHtml(im.caption) << "</figcaption></figure>\n";
    }
  }
  if (scenes > 0) {
    os << "<script>";
    os.write(reinterpret_cast<const char*>(internal::kViewerScript),
             static_cast<std::streamsize>(internal::kViewerScriptSize));
    os << "</script>\n";
  }
  os << "</body></html>\n";
  return os.str();
}

void Report::Write(const std::filesystem::path& path) const {
  const std::string html = ToHtml();
  util::WriteAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << html;
    util::CloseOutput(out, path);
  });
}

}  // namespace fringe::io
