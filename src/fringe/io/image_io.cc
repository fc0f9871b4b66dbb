#include "fringe/io/image_io.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace {

using util::StrCat;

cv::Mat ReadAny(const std::filesystem::path& path) {
  util::RequireFile(path, "image");
  cv::Mat img;
  try {
    img = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw Error(StrCat(path.string(), ": cannot decode image: ", e.what()));
  }
  if (img.empty())
    throw Error(StrCat(path.string(), ": cannot decode image (corrupt or not an image)"));
  return img;
}

void CheckSize(const std::filesystem::path& path, const cv::Mat& img,
               const std::optional<cv::Size>& expected) {
  if (expected && img.size() != *expected) {
    throw Error(StrCat(path.string(), ": image is ", img.cols, "x", img.rows, ", expected ",
                       expected->width, "x", expected->height));
  }
}

}  // namespace

const std::vector<std::string>& ImageExtensions() { return util::ImageExtensions(); }

bool IsImageFile(const std::filesystem::path& path) {
  return util::HasExtension(path, util::ImageExtensions());
}

std::vector<std::string> ListImageFiles(const std::filesystem::path& dir) {
  util::RequireDirectory(dir, "image folder");
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.is_regular_file() && IsImageFile(e.path())) names.push_back(e.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

cv::Mat ReadGrayImage(const std::filesystem::path& path, std::optional<cv::Size> expected_size) {
  cv::Mat img = ReadAny(path);
  if (img.depth() != CV_8U && img.depth() != CV_16U) {
    throw Error(StrCat(path.string(), ": unsupported pixel depth (expected 8- or 16-bit)"));
  }
  if (img.channels() == 3) {
    cv::cvtColor(img, img, cv::COLOR_BGR2GRAY);
  } else if (img.channels() == 4) {
    cv::cvtColor(img, img, cv::COLOR_BGRA2GRAY);
  } else if (img.channels() != 1) {
    throw Error(StrCat(path.string(), ": unsupported number of channels ", img.channels()));
  }
  CheckSize(path, img, expected_size);
  return img;
}

cv::Mat ReadFloatImage(const std::filesystem::path& path, std::optional<cv::Size> expected_size) {
  cv::Mat img = ReadAny(path);
  if (img.type() != CV_32FC1) {
    throw Error(StrCat(path.string(), ": expected a single-channel 32-bit float image"));
  }
  CheckSize(path, img, expected_size);
  return img;
}

void WriteImage(const std::filesystem::path& path, const cv::Mat& image) {
  if (image.empty()) throw Error(StrCat(path.string(), ": refusing to write an empty image"));
  // Encoded in memory and written with a checked stream: cv::imwrite does not check the final
  // flush of its file (libpng's and libtiff's last bytes go out at fclose, whose result OpenCV
  // ignores), so on a full disk it can report success for a truncated file.
  std::vector<uchar> encoded;
  bool ok = false;
  try {
    ok = cv::imencode(path.extension().string(), image, encoded);
  } catch (const cv::Exception& e) {
    throw Error(StrCat(path.string(), ": cannot write image: ", e.what()));
  }
  if (!ok) throw Error(StrCat(path.string(), ": cannot write image (unsupported format?)"));
  util::WriteAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw Error(StrCat(path.string(), ": cannot open for writing"));
    out.write(reinterpret_cast<const char*>(encoded.data()),
              static_cast<std::streamsize>(encoded.size()));
    util::CloseOutput(out, path);
  });
}

}  // namespace fringe::io
