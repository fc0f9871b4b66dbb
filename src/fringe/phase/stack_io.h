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

// Writes into `dir`, atomically (the folder appears complete or not at all):
//   absolute_phase.tiff (CV_32F, projector pixels, NaN invalid), wrapped_phase.tiff,
//   modulation.tiff, background.tiff (CV_32F), mask.png (255 valid), previews
//   absolute_phase_preview.png (valid range stretched to 1..255, 0 invalid) and
//   modulation_preview.png, and summary.json (SummaryToJson).
void WriteDecodeFolder(const std::filesystem::path& dir, const DecodeResult& result);

}  // namespace fringe::phase
