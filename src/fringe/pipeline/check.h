// The measurements `fringe check` takes (eval/check.h): point clouds (PLY, one position each),
// the output folder of `fringe scan` (its views/NNN.ply, one position per view), or a scan
// folder whose views are reconstructed here with a given rig (one position per view). Each
// view of a scan is one position of the artefact in the working volume: the sensor (or the
// artefact) moved between views.
//
// Thread safety: reentrant.
#pragma once

#include <filesystem>
#include <vector>

#include "fringe/eval/check.h"
#include "fringe/pipeline/calibration_files.h"
#include "fringe/stereo/reconstruct_view.h"

namespace fringe::pipeline {

// The rig for scan folders: the calibration fields (calib, opencv, the OpenCV pair,
// opencv_keys; pipeline/calibration_files.h); none given: the scan folder's rig.json.
struct CheckInputOptions : CalibrationFiles {
  stereo::ReconstructionOptions reconstruction;
};

// Throws fringe::Error naming the input when it is neither a PLY file nor a folder of one of the
// kinds above, when a folder holds no view, when a scan folder has no rig, or when a view does
// not reconstruct.
std::vector<eval::CheckInput> ReadCheckInputs(const std::vector<std::filesystem::path>& inputs,
                                              const CheckInputOptions& options = {});

}  // namespace fringe::pipeline
