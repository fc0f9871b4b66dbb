#include "fringe/eval/deviation.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "fringe/util/error.h"

namespace fringe::eval {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

void DeviationOptions::Check() const {
  util::CheckOption(max_distance_mm > 0, "DeviationOptions", "max_distance_mm", max_distance_mm,
                    "must be > 0");
}

std::string DeviationStats::BriefReport() const {
  return util::StrCat("deviation: ", points, " points (", unmatched, " farther than the limit), ",
                      "mean ", mean_mm, " mm, RMS ", rms_mm, " mm, 95% ", p95_mm, " mm, max ",
                      max_mm, " mm");
}

nlohmann::json ToJson(const DeviationStats& s) {
  return {{"points", s.points}, {"unmatched", s.unmatched}, {"mean_mm", s.mean_mm},
          {"rms_mm", s.rms_mm}, {"p95_mm", s.p95_mm},       {"max_mm", s.max_mm}};
}

DeviationStats DeviationFromMesh(const PointCloud& cloud, const MeshIndex& mesh,
                                 const DeviationOptions& options, std::vector<double>* signed_mm) {
  options.Check();
  std::vector<double> d(cloud.size(), kNaN);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, cloud.size(), 1024), [&](const auto& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      d[i] = mesh.SignedDistance(cloud.points[i], options.max_distance_mm);
    }
  });
  DeviationStats s;
  std::vector<double> abs_d;
  abs_d.reserve(d.size());
  double sum = 0, sum_sq = 0;
  for (size_t i = 0; i < d.size(); ++i) {
    if (!cloud.points[i].allFinite()) continue;
    if (!std::isfinite(d[i])) {
      ++s.unmatched;
      continue;
    }
    sum += d[i];
    sum_sq += d[i] * d[i];
    abs_d.push_back(std::abs(d[i]));
  }
  s.points = static_cast<int>(abs_d.size());
  if (s.points > 0) {
    s.mean_mm = sum / s.points;
    s.rms_mm = std::sqrt(sum_sq / s.points);
    const size_t k95 = std::min(abs_d.size() - 1, static_cast<size_t>(0.95 * abs_d.size()));
    std::nth_element(abs_d.begin(), abs_d.begin() + k95, abs_d.end());
    s.p95_mm = abs_d[k95];
    s.max_mm = *std::max_element(abs_d.begin(), abs_d.end());
  }
  if (signed_mm) *signed_mm = std::move(d);
  return s;
}

namespace {

cv::Vec3b Colour(double d, double range_mm) {
  if (!std::isfinite(d)) return cv::Vec3b(40, 40, 40);
  // Diverging map: blue (-range) -> green (0) -> red (+range), BGR.
  const double t = std::clamp(d / range_mm, -1.0, 1.0);
  if (t < 0)
    return cv::Vec3b(static_cast<uint8_t>(255 * -t), static_cast<uint8_t>(255 * (1 + t)), 0);
  return cv::Vec3b(0, static_cast<uint8_t>(255 * (1 - t)), static_cast<uint8_t>(255 * t));
}

}  // namespace

cv::Mat DeviationColorMap(int width, int height, const std::vector<double>& distances,
                          double range_mm) {
  util::CheckOption(range_mm > 0, "DeviationColorMap", "range_mm", range_mm, "must be > 0");
  if (distances.size() != static_cast<size_t>(width) * height) {
    throw Error(util::StrCat("DeviationColorMap: ", distances.size(), " values for a ", width, "x",
                             height, " grid"));
  }
  cv::Mat img(height, width, CV_8UC3);
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      img.at<cv::Vec3b>(r, c) = Colour(distances[static_cast<size_t>(r) * width + c], range_mm);
    }
  }
  return img;
}

cv::Mat DeviationColorMapTopView(const PointCloud& cloud, const std::vector<double>& distances,
                                 double range_mm, int max_size_px) {
  util::CheckOption(range_mm > 0, "DeviationColorMapTopView", "range_mm", range_mm, "must be > 0");
  Eigen::Vector3d mn, mx;
  cloud.Bounds(&mn, &mx);
  if (!mn.allFinite()) return cv::Mat(1, 1, CV_8UC3, cv::Scalar(40, 40, 40));
  const double extent = std::max({mx.x() - mn.x(), mx.y() - mn.y(), 1e-9});
  const double scale = (max_size_px - 1) / extent;
  const int w = static_cast<int>((mx.x() - mn.x()) * scale) + 1;
  const int h = static_cast<int>((mx.y() - mn.y()) * scale) + 1;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(40, 40, 40));
  cv::Mat depth(h, w, CV_64F, cv::Scalar(std::numeric_limits<double>::infinity()));
  for (size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points[i];
    if (!p.allFinite()) continue;
    const int c = static_cast<int>((p.x() - mn.x()) * scale);
    const int r = static_cast<int>((p.y() - mn.y()) * scale);
    if (p.z() < depth.at<double>(r, c)) {  // nearest to a viewer looking along +z
      depth.at<double>(r, c) = p.z();
      img.at<cv::Vec3b>(r, c) = Colour(distances[i], range_mm);
    }
  }
  return img;
}

}  // namespace fringe::eval
