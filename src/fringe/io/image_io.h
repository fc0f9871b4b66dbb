// Image files through OpenCV: 8- and 16-bit grey PNG / TIFF (and anything imread reads), 32-bit
// float TIFF for maps. Errors name the file and the problem.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace fringe::io {

// The image files fringe reads from a folder (fringe stacks, calibration images, captures),
// case-insensitive: util::ImageExtensions(), the one list (names in data files are checked
// against the same list).
const std::vector<std::string>& ImageExtensions();
bool IsImageFile(const std::filesystem::path& path);
// Names (not paths) of the regular image files in `dir`, sorted. Throws fringe::Error when `dir`
// is not a folder.
std::vector<std::string> ListImageFiles(const std::filesystem::path& dir);

// Reads an image as single-channel CV_8U or CV_16U (colour images are converted to grey).
// Throws fringe::Error for a missing file, an undecodable file, an unsupported depth, or a size
// different from `expected_size` when given.
cv::Mat ReadGrayImage(const std::filesystem::path& path,
                      std::optional<cv::Size> expected_size = std::nullopt);

// Reads a single-channel 32-bit float image (TIFF).
cv::Mat ReadFloatImage(const std::filesystem::path& path,
                       std::optional<cv::Size> expected_size = std::nullopt);

// Writes atomically; the format follows the extension. Throws fringe::Error on failure.
void WriteImage(const std::filesystem::path& path, const cv::Mat& image);

}  // namespace fringe::io
