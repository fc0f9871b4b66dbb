#include "fringe/io/report.h"

#include <gtest/gtest.h>

#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "fringe/testing/report.h"
#include "fringe/util/files.h"
#include "fringe_test.h"

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

}  // namespace
}  // namespace fringe::io
