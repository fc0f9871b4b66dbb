#include "fringe/pipeline/calibration_files.h"

#include "fringe/io/calibration_formats.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/opencv_calibration.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/log.h"

namespace fringe::pipeline {
namespace {

namespace fs = std::filesystem;
using util::StrCat;

// A rig JSON is fringe's own file; anything else given as calib is another tool's (as
// `fringe convert-calib` tells them apart).
bool IsRigJson(const fs::path& p) { return util::HasExtension(p, {".json"}); }

}  // namespace

bool CalibrationFiles::empty() const {
  return calib.empty() && opencv.empty() && opencv_intrinsics.empty() && opencv_extrinsics.empty();
}

std::vector<fs::path> CalibrationFiles::Files() const {
  std::vector<fs::path> files;
  if (!calib.empty()) files.push_back(calib);
  files.insert(files.end(), opencv.begin(), opencv.end());
  if (!opencv_intrinsics.empty()) files.push_back(opencv_intrinsics);
  if (!opencv_extrinsics.empty()) files.push_back(opencv_extrinsics);
  return files;
}

void CalibrationFiles::Check(const char* owner) const {
  util::CheckOption(opencv_intrinsics.empty() == opencv_extrinsics.empty(), owner,
                    opencv_intrinsics.empty() ? "opencv_extrinsics" : "opencv_intrinsics",
                    (opencv_intrinsics.empty() ? opencv_extrinsics : opencv_intrinsics).string(),
                    "OpenCV intrinsics and extrinsics go together (--opencv-intrinsics and "
                    "--opencv-extrinsics)");
  util::CheckOption(calib.empty() || (opencv_intrinsics.empty() && opencv.empty()), owner, "calib",
                    calib.string(),
                    "give the calibration either with --calib or as OpenCV files (--opencv, "
                    "--opencv-intrinsics/--opencv-extrinsics), not both");
  util::CheckOption(opencv.empty() || opencv_intrinsics.empty(), owner, "opencv",
                    opencv.empty() ? "" : opencv.front().string(),
                    "give other tools' files either with --opencv or as the "
                    "--opencv-intrinsics/--opencv-extrinsics pair, not both");
  util::CheckOption(opencv_keys.empty() || (!calib.empty() && !IsRigJson(calib)) ||
                        !opencv.empty() || !opencv_intrinsics.empty(),
                    owner, "opencv_keys", opencv_keys.size(),
                    "--opencv-keys names the keys of calibration files given with --opencv (or "
                    "--calib of another tool's file); a rig JSON has fringe's own keys");
}

std::optional<ResolvedRig> LookUpRig(const CalibrationFiles& files, const RigReadOptions& read,
                                     const std::vector<fs::path>& defaults) {
  files.Check();
  ResolvedRig r;
  if (files.empty()) {
    for (const fs::path& d : defaults) {
      if (!fs::exists(d)) continue;
      r.rig = io::ReadRig(d);
      r.source = d.string();
      return r;
    }
    return std::nullopt;
  }
  if (!files.calib.empty() && IsRigJson(files.calib)) {
    r.rig = io::ReadRig(files.calib);
    r.source = files.calib.string();
    return r;
  }
  const std::vector<fs::path> paths = files.Files();
  for (const fs::path& f : paths) r.source += (r.source.empty() ? "" : " + ") + f.string();
  io::CalibrationReadOptions o;
  o.camera_width = read.camera_width;
  o.camera_height = read.camera_height;
  o.projector_width = read.projector_width;
  o.projector_height = read.projector_height;
  o.keys = io::CalibrationKeyMap::Parse(files.opencv_keys);
  const io::OpenCvCalibration cv = io::ReadCalibration(paths, o);
  util::LogInfo("calibration " + r.source + ":\n" + cv.Describe());
  const bool stereo = read.devices == RigDevices::kStereo ||
                      (read.devices == RigDevices::kAuto && cv.right && cv.right_from_left);
  if (stereo && !cv.right && !read.stereo_needed_by.empty()) {
    throw Error(StrCat(r.source, ": holds no right camera, but ", read.stereo_needed_by));
  }
  r.rig = stereo ? cv.ToRig(r.source) : cv.ToCameraProjectorRig(r.source);
  return r;
}

}  // namespace fringe::pipeline
