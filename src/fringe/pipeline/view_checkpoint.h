// A finished view of `fringe scan`, kept beside its outputs in the temporary output folder
// (OUT's hidden temporary, .resume/NAME.view) so that `fringe scan --resume` after a crash or a
// kill reuses it instead of decoding and reconstructing the view again (docs/scan-folder.md,
// "Resuming"). A checkpoint is a cache, not an output: it is written without fsync, it carries a
// checksum and the key of what produced it, and anything that does not match (another key, a
// torn or foreign file) is ignored and the view redone. The folder is removed before OUT is
// committed. Internal to the pipeline module.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "fringe/geometry/point_cloud.h"
#include "fringe/pipeline/report.h"
#include "fringe/pipeline/scan.h"
#include "fringe/registration/markers.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/util/files.h"

namespace fringe::pipeline {

// One view through the views stage of RunScan.
struct ViewResult {
  ScanViewSummary summary;
  OrganizedPointCloud cloud;
  std::vector<registration::ViewMarker> markers;
  std::vector<ReportImage> pictures;
  cv::Mat phase_left;  // kept for the projector-column check (empty when it is not run)
};

// Folder of the checkpoints inside a (temporary) output folder.
inline constexpr const char* kCheckpointFolder = util::kResumeFolder;

// What a view's result depends on, as text: the caller's options (ScanOptions::resume_key), the
// rig and schemes as used, and every file of the view folder (relative name, size, modification
// time), so that a changed image, rig or option never reuses a stale view.
std::string ViewCheckpointKey(const scan::ScanFolder& folder, const std::string& view,
                              const std::string& rig_and_schemes, const std::string& options_key);

// Writes `v` (a view that worked) to dir/.resume/NAME.view (temporary name, then rename; no
// fsync: a cache) and returns the bytes written. Throws fringe::Error on a write failure.
uint64_t WriteViewCheckpoint(const std::filesystem::path& dir, const std::string& key,
                         const ViewResult& v);

// The checkpoint of view `name` in dir/.resume when it exists, is whole (checksum) and has
// `key`; nullopt otherwise (the view is then redone). Never throws for a bad file.
std::optional<ViewResult> ReadViewCheckpoint(const std::filesystem::path& dir,
                                             const std::string& name, const std::string& key);

}  // namespace fringe::pipeline
