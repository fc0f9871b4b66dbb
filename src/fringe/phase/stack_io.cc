#include "fringe/phase/stack_io.h"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <set>

#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::phase {
namespace {

using util::StrCat;

// Checked writes (io::WriteImage): cv::imwrite can report success for a truncated file.
void Write(const std::filesystem::path& path, const cv::Mat& m) { io::WriteImage(path, m); }

}  // namespace

std::vector<cv::Mat> ReadStack(const std::filesystem::path& dir, const PatternScheme& scheme) {
  util::RequireDirectory(dir, "image stack");
  const auto names = scheme.ImageNames();
  const std::set<std::string> expected(names.begin(), names.end());
  std::vector<std::string> extra;
  std::error_code ec;
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const auto name = it->path().filename().string();
    std::error_code fec;
    if (it->is_regular_file(fec) && io::IsImageFile(it->path()) && !expected.count(name)) {
      extra.push_back(name);
    }
  }
  if (ec) throw Error(StrCat(dir.string(), ": cannot list image stack: ", ec.message()));
  if (!extra.empty()) {
    std::sort(extra.begin(), extra.end());
    throw Error(
        StrCat((dir / extra[0]).string(), ": image not in the scheme '", scheme.name,
               "' (which lists ", names.size(), " images",
               extra.size() > 1 ? StrCat("; ", extra.size(), " extra files") : std::string(), ")"));
  }
  std::vector<cv::Mat> images;
  for (const auto& n : names) {
    const auto path = dir / n;
    std::error_code eec;
    if (!std::filesystem::exists(std::filesystem::symlink_status(path, eec))) {
      throw Error(StrCat(path.string(), ": missing image ", images.size(), " of the ", names.size(),
                         " the scheme '", scheme.name, "' lists"));
    }
    std::optional<cv::Size> size;
    if (!images.empty()) size = images[0].size();
    images.push_back(io::ReadGrayImage(path, size));
    if (images.back().depth() != images[0].depth()) {
      throw Error(StrCat(path.string(), ": bit depth differs from ", (dir / names[0]).string()));
    }
  }
  return images;
}

std::filesystem::path ExposureDir(const std::filesystem::path& dir, int exposure) {
  return dir / StrCat("e", exposure);
}

bool HasExposureFolders(const std::filesystem::path& dir) {
  std::error_code ec;
  return std::filesystem::is_directory(ExposureDir(dir, 0), ec);
}

std::vector<std::vector<cv::Mat>> ReadExposureStacks(const std::filesystem::path& dir,
                                                     const PatternScheme& scheme) {
  if (!HasExposureFolders(dir)) return {ReadStack(dir, scheme)};
  // Images beside the exposure folders would be ambiguous (a forgotten stack, or a misplaced
  // exposure): refused.
  std::error_code ec;
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code fec;
    if (it->is_regular_file(fec) && io::IsImageFile(it->path())) {
      throw Error(StrCat(it->path().string(), ": image beside the exposure folders ",
                         ExposureDir(dir, 0).filename().string(),
                         "/...; put every image of an exposure in its folder"));
    }
  }
  if (ec) throw Error(StrCat(dir.string(), ": cannot list image stack: ", ec.message()));
  std::vector<std::vector<cv::Mat>> stacks;
  for (int e = 0; std::filesystem::is_directory(ExposureDir(dir, e), ec); ++e) {
    if (e >= kMaxExposures) {
      throw Error(
          StrCat(ExposureDir(dir, e).string(), ": more than ", kMaxExposures, " exposures"));
    }
    stacks.push_back(ReadStack(ExposureDir(dir, e), scheme));
    const cv::Mat& first = stacks.front().front();
    const cv::Mat& now = stacks.back().front();
    if (now.size() != first.size() || now.type() != first.type()) {
      throw Error(StrCat(ExposureDir(dir, e).string(), ": images are ", now.cols, "x", now.rows,
                         " of ", now.elemSize() * 8, " bits, those of ",
                         ExposureDir(dir, 0).string(), " are ", first.cols, "x", first.rows, " of ",
                         first.elemSize() * 8, " bits"));
    }
  }
  return stacks;
}

void WriteDecodeFolder(const std::filesystem::path& dir, const DecodeResult& r) {
  util::WriteFolderAtomically(dir, [&](const std::filesystem::path& tmp) {
    Write(tmp / "absolute_phase.tiff", r.absolute_phase);
    Write(tmp / "wrapped_phase.tiff", r.wrapped_phase);
    Write(tmp / "modulation.tiff", r.modulation);
    Write(tmp / "background.tiff", r.background);
    Write(tmp / "mask.png", r.mask);
    double lo = 0, hi = 1;
    if (r.summary.valid > 0) cv::minMaxLoc(r.absolute_phase, &lo, &hi, nullptr, nullptr, r.mask);
    cv::Mat preview;
    r.absolute_phase.convertTo(preview, CV_8U, 254.0 / std::max(hi - lo, 1e-6),
                               1.0 - 254.0 * lo / std::max(hi - lo, 1e-6));
    preview.setTo(0, r.mask == 0);
    Write(tmp / "absolute_phase_preview.png", preview);
    double mod_hi = 1;
    cv::minMaxLoc(r.modulation, nullptr, &mod_hi);
    r.modulation.convertTo(preview, CV_8U, 255.0 / std::max(mod_hi, 1e-6));
    Write(tmp / "modulation_preview.png", preview);
    io::WriteJson(tmp / "summary.json", ToJson(r.summary));
  });
}

}  // namespace fringe::phase
