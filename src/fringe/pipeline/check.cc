#include "fringe/pipeline/check.h"

#include <algorithm>

#include "fringe/io/calibration_io.h"
#include "fringe/io/ply.h"
#include "fringe/pipeline/result_layout.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/stereo/camera_projector.h"
#include "fringe/util/error.h"
#include "fringe/util/log.h"

namespace fringe::pipeline {
namespace {

namespace fs = std::filesystem;
using util::StrCat;

// Every view of a scan folder, reconstructed with the rig (stereo, or the camera against the
// calibrated projector for one-camera scans); the first exposure of each stack is enough for an
// artefact check, and reading one keeps memory to one view.
void ReconstructScanViews(const fs::path& root, const CheckInputOptions& options,
                          std::vector<eval::CheckInput>* out) {
  const scan::ScanFolder folder = scan::ScanFolder::Open(root);
  if (!folder.has_views()) throw Error(StrCat(root.string(), ": the scan folder has no views"));
  const std::vector<phase::PatternScheme> schemes = folder.ReadSchemes();
  RigReadOptions read;
  read.devices = folder.stereo() ? RigDevices::kStereo : RigDevices::kCameraProjector;
  read.camera_width = folder.manifest().image_width;
  read.camera_height = folder.manifest().image_height;
  read.projector_width = schemes.front().projector_width;
  read.projector_height = schemes.front().projector_height;
  const std::optional<ResolvedRig> resolved = LookUpRig(options, read, {folder.layout().Rig()});
  if (!resolved) {
    throw Error(StrCat(root.string(),
                       ": no rig to reconstruct the views with (give --calib RIG or --opencv, or "
                       "put rig.json in the scan folder)"));
  }
  const StereoRig& rig = resolved->rig;
  const stereo::ViewReconstructor reconstructor =
      folder.stereo()
          ? stereo::ViewReconstructor(rig, schemes.front(), options.reconstruction)
          : stereo::MakeCameraProjectorReconstructor(
                stereo::CameraProjectorRig::FromLeftCamera(rig), schemes, options.reconstruction);
  for (const std::string& view : folder.views()) {
    util::LogInfo(StrCat("check: reconstructing view ", view, " of ", root.string()));
    stereo::ViewStacks stacks;
    for (auto& exposures : folder.ReadViewStacks(view, scan::Camera::kLeft, schemes)) {
      stacks.left.push_back(std::move(exposures.front()));
    }
    if (folder.stereo()) {
      for (auto& exposures : folder.ReadViewStacks(view, scan::Camera::kRight, schemes)) {
        stacks.right.push_back(std::move(exposures.front()));
      }
    }
    const stereo::ViewReconstruction rec = reconstructor.Reconstruct(stacks);
    if (!rec.summary.ok()) {
      throw Error(
          StrCat(root.string(), ": view ", view, " did not reconstruct: ", rec.summary.message));
    }
    out->push_back({StrCat(root.filename().string(), "/", view), rec.cloud.Compact()});
  }
}

}  // namespace

std::vector<eval::CheckInput> ReadCheckInputs(const std::vector<fs::path>& inputs,
                                              const CheckInputOptions& options) {
  std::vector<eval::CheckInput> out;
  for (const fs::path& in : inputs) {
    if (fs::is_regular_file(in)) {
      out.push_back({in.filename().string(), io::ReadPly(in).cloud});
    } else if (fs::is_directory(in) && scan::ScanFolder::IsScanFolder(in)) {
      ReconstructScanViews(in, options, &out);
    } else if (fs::is_directory(ResultLayout{in}.ViewsDir())) {
      // The output of `fringe scan`: one cloud per view.
      std::vector<fs::path> clouds;
      for (const auto& e : fs::directory_iterator(ResultLayout{in}.ViewsDir())) {
        if (e.is_regular_file() && e.path().extension() == ".ply") clouds.push_back(e.path());
      }
      if (clouds.empty()) {
        throw Error(StrCat(in.string(), ": views/ holds no view cloud (NNN.ply)"));
      }
      std::sort(clouds.begin(), clouds.end());
      for (const fs::path& c : clouds) {
        out.push_back({StrCat(in.filename().string(), "/views/", c.filename().string()),
                       io::ReadPly(c).cloud});
      }
    } else if (fs::is_directory(in)) {
      throw Error(StrCat(in.string(),
                         ": neither a scan folder (scan.json) nor the output of fringe scan "
                         "(views/NNN.ply)"));
    } else {
      throw Error(StrCat(in.string(), ": no such file or folder"));
    }
  }
  return out;
}

}  // namespace fringe::pipeline
