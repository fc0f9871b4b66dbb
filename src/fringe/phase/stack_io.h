// Reading an image stack described by a scheme manifest, and writing decode results.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <vector>

#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"

namespace fringe::phase {

// Reads scheme.ImageNames() from `dir` (8- or 16-bit grey). Throws fringe::Error naming the file
// for a missing image, an image of another size or bit depth than the first, or an extra image
// file in `dir` (any io::IsImageFile not in the manifest).
std::vector<cv::Mat> ReadStack(const std::filesystem::path& dir, const PatternScheme& scheme);

// One camera's stack at one or several exposures (DecodeExposures). A folder holding a
// sub-folder "e0" holds exposures: e0/, e1/, ... (consecutive from 0, at most kMaxExposures),
// each a stack ReadStack reads, all of one size and bit depth; the folder itself then holds no
// image (an error naming it). Any other folder is one exposure: {ReadStack(dir, scheme)}.
std::vector<std::vector<cv::Mat>> ReadExposureStacks(const std::filesystem::path& dir,
                                                     const PatternScheme& scheme);
// The folder of exposure e of a camera folder: dir / "e<e>".
std::filesystem::path ExposureDir(const std::filesystem::path& dir, int exposure);
// Whether `dir` holds exposure folders (ReadExposureStacks).
bool HasExposureFolders(const std::filesystem::path& dir);

// Writes into `dir`, atomically (the folder appears complete or not at all):
//   absolute_phase.tiff (CV_32F, projector pixels, NaN invalid), wrapped_phase.tiff,
//   modulation.tiff, background.tiff (CV_32F), mask.png (255 valid), previews
//   absolute_phase_preview.png (valid range stretched to 1..255, 0 invalid) and
//   modulation_preview.png, and summary.json (ToJson).
void WriteDecodeFolder(const std::filesystem::path& dir, const DecodeResult& result);

}  // namespace fringe::phase
