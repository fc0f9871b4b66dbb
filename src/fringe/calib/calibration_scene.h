// The calibration report's 3D view (docs/formats.md, "The report's 3D view"): the board at every
// used pose (its outline and its features) and every device of the calibration (cameras,
// projector) as a frustum at its calibrated pose, in the reference (first) camera's frame, the
// boards and features coloured by the pose's reprojection residual. The same scene format and
// viewer (web/viewer) as the scan report's.
//
// Frames: the reference camera frame, mm. Thread safety: reentrant.
#pragma once

#include <vector>

#include "fringe/calib/diagnostics.h"
#include "fringe/geometry/calibration_target.h"
#include "fringe/io/report.h"

namespace fringe::calib {

// `devices` as for CalibrationReport (devices[0] the reference camera, whose camera_from_board
// places the poses); `d` its diagnostics (pose names, used flags, per-device residuals). A device
// is placed by device_from_reference = device_from_board * (reference_from_board)^-1 at the first
// pose both used (exact for a joint solution, where every device's board pose is its
// device_from_reference times the reference's); a device that shares no used pose with the
// reference is left out (its frustum would have no place).
io::ReportScene CalibrationScene(const CalibrationDiagnostics& d,
                                 const std::vector<DiagnosedDevice>& devices,
                                 const CalibrationTarget& target);

}  // namespace fringe::calib
