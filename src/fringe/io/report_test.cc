#include "fringe/io/report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fringe/testing/fringe_test.h"
#include "fringe/testing/report.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace {

TEST(Report, Base64MatchesRfc4648Vectors) {
  auto enc = [](const std::string& s) { return Base64(std::vector<uint8_t>(s.begin(), s.end())); };
  EXPECT_EQ(enc(""), "");
  EXPECT_EQ(enc("f"), "Zg==");
  EXPECT_EQ(enc("fo"), "Zm8=");
  EXPECT_EQ(enc("foo"), "Zm9v");
  EXPECT_EQ(enc("foob"), "Zm9vYg==");
  EXPECT_EQ(enc("fooba"), "Zm9vYmE=");
  EXPECT_EQ(enc("foobar"), "Zm9vYmFy");
}

TEST(Report, ColourMapShowsNaNAsGreyAndAddsABar) {
  cv::Mat values(100, 200, CV_32F);
  for (int r = 0; r < values.rows; ++r) {
    for (int c = 0; c < values.cols; ++c) values.at<float>(r, c) = static_cast<float>(c);
  }
  values(cv::Rect(0, 0, 50, 50)).setTo(std::numeric_limits<float>::quiet_NaN());
  const cv::Mat m = ColourMapWithBar(values, 0, 199, "x, mm", 100);
  ASSERT_EQ(m.type(), CV_8UC3);
  EXPECT_EQ(m.cols, 100);
  EXPECT_GT(m.rows, 50);  // 50 rows of map plus the bar
  EXPECT_EQ(m.at<cv::Vec3b>(5, 5), cv::Vec3b(48, 48, 48));
  // Low values blue-ish, high values red-ish (turbo).
  const cv::Vec3b low = m.at<cv::Vec3b>(40, 30), high = m.at<cv::Vec3b>(40, 98);
  EXPECT_GT(low[0], low[2]);
  EXPECT_GT(high[2], high[0]);
  const auto range = DisplayRange(values, 0.0);
  EXPECT_FLOAT_EQ(range[0], 0.f);
  EXPECT_FLOAT_EQ(range[1], 199.f);
}

TEST(DeviationRange, FromDataIsAHighPercentileOfTheMagnitudeNotTheOutliers) {
  // A constructed deviation set: 950 values 0.0001 mm apart from -0.0475 to +0.0474 mm (the
  // measurement's noise), 20 gross outliers of -2 mm and 30 of +3 mm (spikes at an edge, 5 %),
  // and NaNs (no value) that must not count. The 95th percentile of |d| (nearest rank: the
  // 950th of the 1000 magnitudes) is the largest noise magnitude, 0.0475 mm: the outliers
  // saturate.
  std::vector<double> d;
  for (int i = 0; i < 950; ++i) d.push_back(-0.0475 + 0.0001 * i);
  d.insert(d.end(), 20, -2.0);
  d.insert(d.end(), 30, 3.0);
  d.insert(d.end(), 7, std::numeric_limits<double>::quiet_NaN());
  const DeviationRange r = DeviationRange::FromData(d);
  EXPECT_FALSE(r.from_tolerance);
  EXPECT_DOUBLE_EQ(r.percentile, 95);
  EXPECT_NEAR(r.half_range_mm, 0.0475, 1e-12);
  EXPECT_DOUBLE_EQ(r.lo(), -r.hi());
  // Another percentile: the 99th lies among the outliers; the 100th is the largest.
  EXPECT_DOUBLE_EQ(DeviationRange::FromData(d, 99).half_range_mm, 3.0);
  EXPECT_DOUBLE_EQ(DeviationRange::FromData(d, 96).half_range_mm, 2.0);
  EXPECT_DOUBLE_EQ(DeviationRange::FromData(d, 100).half_range_mm, 3.0);
  EXPECT_NE(r.Legend("signed deviation, mm").find("95th percentile of |deviation|"),
            std::string::npos);
  // Nothing to go by: a small range, not an empty one.
  EXPECT_GT(DeviationRange::FromData({}).half_range_mm, 0);
  EXPECT_GT(DeviationRange::FromData({0, 0, 0}).half_range_mm, 0);
  EXPECT_THROW(DeviationRange::FromData(d, 0), Error);
}

TEST(DeviationRange, ToleranceIsTheRangeAndTheLegendSaysSo) {
  const DeviationRange r = DeviationRange::FromTolerance(0.1);
  EXPECT_TRUE(r.from_tolerance);
  EXPECT_DOUBLE_EQ(r.lo(), -0.1);
  EXPECT_DOUBLE_EQ(r.hi(), 0.1);
  const std::string legend = r.Legend("signed deviation from truth, mm");
  EXPECT_NE(legend.find("+-0.1"), std::string::npos) << legend;
  EXPECT_NE(legend.find("tolerance"), std::string::npos) << legend;
  EXPECT_THROW(DeviationRange::FromTolerance(0), Error);
  EXPECT_THROW(DeviationRange::FromTolerance(-1), Error);
  EXPECT_THROW(DeviationRange::FromTolerance(std::nan("")), Error);
}

TEST(Report, HistogramBarsFollowTheCounts) {
  // 90 values in the left half, 10 in the right: the left bar is far taller.
  std::vector<double> v(90, -0.5);
  v.insert(v.end(), 10, 0.5);
  const cv::Mat img = HistogramImage(v, -1, 1, 2, "mm", {}, 200, 200);
  auto bar_height = [&](int col) {
    int n = 0;
    for (int r = 0; r < img.rows; ++r) {
      const cv::Vec3b p = img.at<cv::Vec3b>(r, col);
      n += p == cv::Vec3b(180, 110, 40);
    }
    return n;
  };
  const int left = bar_height(50), right = bar_height(150);
  EXPECT_GT(left, 0);
  EXPECT_NEAR(double(right) / left, 10.0 / 90.0, 0.03);
}

TEST(Report, HtmlIsSelfContainedAndEveryImageDecodes) {
  Report r;
  r.title = "t <&>";
  ReportSection s;
  s.title = "section";
  s.paragraphs.push_back("a < b");
  s.tables.push_back({"caption", {"a", "b"}, {{"1", "2"}}});
  s.images.push_back({"grey", cv::Mat(10, 20, CV_8U, cv::Scalar(7))});
  s.images.push_back({"colour", cv::Mat(5, 6, CV_8UC3, cv::Scalar(1, 2, 3))});
  r.sections.push_back(s);
  test::TempDir dir;
  r.Write(dir / "report.html");
  const std::string html = util::ReadTextFile(dir / "report.html");
  EXPECT_EQ(html.find("://"), std::string::npos);  // no external URL (base64 has no colon)
  EXPECT_NE(html.find("t &lt;&amp;&gt;"), std::string::npos);
  int sources = 0;
  const std::vector<cv::Mat> images = testing::EmbeddedImages(html, &sources);
  EXPECT_EQ(sources, 2);
  ASSERT_EQ(images.size(), 2u);
  EXPECT_EQ(images[0].size(), cv::Size(20, 10));
  EXPECT_EQ(images[1].type(), CV_8UC3);
  EXPECT_EQ(html.find("<img src=\"http"), std::string::npos);
}

// Noise-like colour maps (the pictures of measured data) go as JPEG when that halves the PNG,
// close to the picture; flat plots stay PNG, exact.
TEST(Report, NoisyPicturesAreJpegCloseToThePictureAndFlatOnesExactPng) {
  // JPEG keeps what a reader sees, the map's local level (5 x 5 means), to a fraction of a DN;
  // pixel by pixel it differs by about the noise (8 DN here), which it partly smooths away.
  constexpr double kMaxLocalMeanDn = 1;
  constexpr double kMaxPixelDn = 8;
  cv::Mat noisy(200, 240, CV_8UC3), flat(200, 240, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::RNG rng(7);
  for (int r = 0; r < noisy.rows; ++r) {
    for (int c = 0; c < noisy.cols; ++c) {
      const double v = 128 + 60 * std::sin(c * 0.05) + rng.gaussian(8);
      noisy.at<cv::Vec3b>(r, c) =
          cv::Vec3b(cv::saturate_cast<uint8_t>(v), cv::saturate_cast<uint8_t>(255 - v),
                    cv::saturate_cast<uint8_t>(0.5 * v));
    }
  }
  cv::rectangle(flat, {20, 20}, {120, 150}, cv::Scalar(200, 30, 30), cv::FILLED);
  Report r;
  ReportSection s;
  s.images.push_back({"noisy", noisy});
  s.images.push_back({"flat", flat});
  r.sections.push_back(s);
  const std::string html = r.ToHtml();
  EXPECT_NE(html.find("<img src=\"data:image/jpeg;base64,"), std::string::npos);
  EXPECT_NE(html.find("<img src=\"data:image/png;base64,"), std::string::npos);
  int sources = 0;
  const std::vector<cv::Mat> images = testing::EmbeddedImages(html, &sources);
  ASSERT_EQ(images.size(), 2u);
  ASSERT_EQ(images[0].size(), noisy.size());
  const auto mean_abs_dn = [](const cv::Mat& a, const cv::Mat& b) {
    cv::Mat diff;
    cv::absdiff(a, b, diff);
    const cv::Scalar m = cv::mean(diff);
    return (m[0] + m[1] + m[2]) / 3;
  };
  cv::Mat local_jpeg, local_noisy;
  cv::blur(images[0], local_jpeg, {5, 5});
  cv::blur(noisy, local_noisy, {5, 5});
  EXPECT_LT(mean_abs_dn(local_jpeg, local_noisy), kMaxLocalMeanDn);
  EXPECT_LT(mean_abs_dn(images[0], noisy), kMaxPixelDn);
  EXPECT_EQ(cv::norm(images[1], flat, cv::NORM_INF), 0);
}

TEST(Report, SceneIsEmbeddedAsJsonAndOneBase64BlockWithTheViewerScript) {
  ReportScene scene;
  scene.description["title"] = "a </script><!-- b";
  scene.AddArray("a", std::vector<float>{1.5f, -2.f});
  scene.AddArray("b", std::vector<uint8_t>{7});
  scene.AddArray("c", std::vector<uint32_t>{1u << 31});  // aligned after b's one byte
  scene.AddArray("d", std::vector<uint16_t>{});
  EXPECT_THROW(scene.AddArray("a", std::vector<float>{}), Error);
  const nlohmann::json& arrays = scene.description["arrays"];
  EXPECT_EQ(arrays["a"]["offset"], 0);
  EXPECT_EQ(arrays["a"]["type"], "float32");
  EXPECT_EQ(arrays["b"]["offset"], 8);
  EXPECT_EQ(arrays["c"]["offset"], 12);
  EXPECT_EQ(arrays["c"]["count"], 1);
  float a1;
  std::memcpy(&a1, scene.bytes().data() + 4, 4);
  EXPECT_EQ(a1, -2.f);

  Report r;
  r.title = "t";
  ReportSection s;
  s.title = "model";
  s.paragraphs.push_back("text");
  s.scene = scene;
  s.images.push_back({"picture", cv::Mat(5, 6, CV_8UC3, cv::Scalar(1, 2, 3))});
  r.sections.push_back(s);
  const std::string html = r.ToHtml();
  // The description parses back (its '<' escaped: the script element is not closed early).
  const std::string open = "<script type=\"application/json\" id=\"fringe-scene-0-description\">";
  const size_t begin = html.find(open) + open.size(), end = html.find("</script>", begin);
  ASSERT_NE(html.find(open), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(html.substr(begin, end - begin)), scene.description);
  // The arrays, deflated, inflate to the block (and the page states its size).
  EXPECT_NE(html.find("<script type=\"application/octet-stream\" data-encoding=\"deflate\" "
                      "data-bytes=\"" +
                      std::to_string(scene.bytes().size()) + "\" id=\"fringe-scene-0-arrays\">"),
            std::string::npos);
  EXPECT_EQ(testing::EmbeddedSceneBytes(html), scene.bytes());
  // The container with its message for a browser without JavaScript, before the pictures; the
  // viewer script once, at the end; no external source.
  const size_t container = html.find("<div class=\"fringe-scene\" id=\"fringe-scene-0\">");
  ASSERT_NE(container, std::string::npos);
  EXPECT_LT(container, html.find("<img"));
  EXPECT_NE(html.find("needs JavaScript and WebGL"), std::string::npos);
  const size_t script = html.find("<script>");
  ASSERT_NE(script, std::string::npos);
  EXPECT_EQ(html.find("<script>", script + 1), std::string::npos);
  EXPECT_NE(html.find("fringeViewer", script), std::string::npos);
  for (const char* external : {"src=\"http", "src=\"//", "href=\"http", "import(", "fetch("}) {
    EXPECT_EQ(html.find(external), std::string::npos) << external;
  }
  // A page without a scene has no script.
  r.sections[0].scene.reset();
  EXPECT_EQ(r.ToHtml().find("<script"), std::string::npos);
}

}  // namespace
}  // namespace fringe::io
