#include "fringe/io/image_io.h"

#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "fringe/testing/file_size_limit.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::io {
namespace {

void ExpectErrorContains(const std::function<void()>& f, const std::string& a,
                         const std::string& b) {
  try {
    f();
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(a), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(b), std::string::npos) << e.what();
  }
}

TEST(ImageIo, RoundTrip8And16BitPngTiffAndFloat) {
  test::TempDir dir;
  cv::Mat img8(20, 30, CV_8UC1), img16(20, 30, CV_16UC1), imgf(20, 30, CV_32FC1);
  cv::randu(img8, 0, 255);
  cv::randu(img16, 0, 65535);
  cv::randu(imgf, -1e3, 1e3);
  for (const char* ext : {".png", ".tif"}) {
    WriteImage(dir / (std::string("a8") + ext), img8);
    WriteImage(dir / (std::string("a16") + ext), img16);
    EXPECT_EQ(cv::norm(ReadGrayImage(dir / (std::string("a8") + ext)), img8, cv::NORM_INF), 0);
    const cv::Mat r16 = ReadGrayImage(dir / (std::string("a16") + ext));
    EXPECT_EQ(r16.depth(), CV_16U);
    EXPECT_EQ(cv::norm(r16, img16, cv::NORM_INF), 0);
  }
  WriteImage(dir / "f.tif", imgf);
  EXPECT_EQ(cv::norm(ReadFloatImage(dir / "f.tif"), imgf, cv::NORM_INF), 0);
}

// A full disk (a file size limit, tests/file_size_limit.h) that cuts the last bytes of a PNG:
// cv::imwrite returns true for that truncated file (libpng's final bytes go out at an unchecked
// fclose); WriteImage encodes in memory and checks its own writes, so it fails naming the file
// and leaves nothing. Float TIFF (the truth maps) the same.
TEST(ImageIo, FullDiskFailsNamingTheFileAndLeavesNothing) {
  test::TempDir dir;
  cv::Mat img8(64, 64, CV_8UC1);
  cv::randu(img8, 0, 255);
  cv::Mat imgf;
  img8.convertTo(imgf, CV_32F);
  for (const auto& [name, image] : {std::pair<std::string, cv::Mat>{"a.png", img8},
                                    std::pair<std::string, cv::Mat>{"a.tiff", imgf}}) {
    std::vector<uchar> encoded;
    ASSERT_TRUE(cv::imencode(std::filesystem::path(name).extension().string(), image, encoded));
    const std::filesystem::path path = dir / name;
    std::string message;
    {
      const test::FileSizeLimit limit(encoded.size() - 28);
      message = test::ErrorOf([&] { WriteImage(path, image); });
    }
    EXPECT_NE(message.find(path.string() + ": cannot write: File too large"), std::string::npos)
        << message;
    EXPECT_TRUE(std::filesystem::is_empty(dir.path())) << name;
    const test::FileSizeLimit limit(encoded.size());
    WriteImage(path, image);
    const cv::Mat back = image.type() == CV_32F ? ReadFloatImage(path) : ReadGrayImage(path);
    EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0) << name;
    std::filesystem::remove(path);
  }
}

TEST(ImageIo, ColourBecomesGrey) {
  test::TempDir dir;
  cv::Mat bgr(8, 8, CV_8UC3, cv::Scalar(10, 20, 30));
  cv::imwrite((dir / "c.png").string(), bgr);
  const cv::Mat g = ReadGrayImage(dir / "c.png");
  EXPECT_EQ(g.channels(), 1);
}

TEST(ImageIo, ClearErrors) {
  test::TempDir dir;
  ExpectErrorContains([&] { ReadGrayImage(dir / "missing.png"); }, "missing.png", "no such file");
  {
    std::ofstream f(dir / "corrupt.png", std::ios::binary);
    f << "\x89PNG\r\n\x1a\n garbage";
  }
  ExpectErrorContains([&] { ReadGrayImage(dir / "corrupt.png"); }, "corrupt.png", "decode");
  WriteImage(dir / "small.png", cv::Mat(10, 12, CV_8UC1, cv::Scalar(3)));
  ExpectErrorContains([&] { ReadGrayImage(dir / "small.png", cv::Size(1280, 1024)); }, "small.png",
                      "12x10, expected 1280x1024");
  ExpectErrorContains([&] { WriteImage(dir / "nodir" / "x.png", cv::Mat(2, 2, CV_8UC1)); }, "x.png",
                      "does not exist");
}

}  // namespace
}  // namespace fringe::io
