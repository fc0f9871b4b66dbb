// What the scanner's stages hand to the report and the truth comparison (pipeline/scan.cc,
// pipeline/scan_report.cc, pipeline/scan_truth.cc): internal to the pipeline module, not an API.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fringe/calib/calibrate_folder.h"
#include "fringe/calib/projector_folder.h"
#include "fringe/fusion/fuse.h"
#include "fringe/fusion/mesh.h"
#include "fringe/io/report.h"
#include "fringe/pipeline/report.h"
#include "fringe/pipeline/scan.h"
#include "fringe/pipeline/view_checkpoint.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/register_views.h"
#include "fringe/scan/scan_folder.h"

namespace fringe::pipeline::internal {

constexpr int kPictureWidthPx = 480;  // the report's per-view pictures

// The rig the scan runs with, where it came from, and the calibration results when it was
// calibrated from the scan folder's boards (for rig.json and the report's calibration section).
struct Calibration {
  StereoRig rig;
  std::string source;
  std::optional<calib::FolderCalibration> folder;  // when calibrated from board images here
  // One camera + projector, calibrated here from the board pose folders.
  std::optional<calib::ProjectorFolderCalibration> projector_folder;
  CalibrationTarget target;  // the board, when calibrated here (for the diagnostics)
};

// Everything registration, fusion, meshing and the truth comparison hand to the report.
struct Model {
  std::vector<int> view_of;    // per registration input: index into the scan's views
  std::vector<int> fusion_of;  // per registration input: index of its fusion view, or -1
  std::vector<std::vector<uint8_t>> grid_valid;  // per registration input: its grid's mask
  std::vector<cv::Size> grid_size;               // per registration input: its grid's size
  std::vector<registration::RegistrationView> inputs;
  registration::RegistrationResult registration;
  fusion::FusionResult fused;
  fusion::MeshResult mesh;
  // Pictures are drawn in a display frame with z up: the truth's world when there is one (via
  // the gauge), else the frame whose z is opposite the views' mean viewing direction.
  Rigid3d display_from_world;
  // Point-to-plane residuals between overlapping views (sampled), at the poses after the global
  // marker adjustment and after ICP, and the marker sightings' distances to the map.
  std::vector<double> residuals_adjusted_mm, residuals_final_mm, marker_residuals_mm;
  double residual_threshold_mm = 0;
  std::vector<double> mesh_deviation_mm;    // per mesh vertex, signed, vs truth (empty without)
  io::DeviationRange mesh_deviation_range;  // its colours in the pictures and the 3D view
  // Per registration input, with truth: the signed deviation of the view's points placed by
  // their true pose, on its grid shrunk to the picture's width (CV_32F, NaN: no point); empty
  // without truth or for a view that was not placed.
  std::vector<cv::Mat> view_deviation_mm;
};

// Every k-th index so that at most max_count of n remain (deterministic, spread over the grid).
std::vector<size_t> Stride(size_t n, size_t max_count);

// RMS of the finite values, NaN without one.
double Rms(const std::vector<double>& v);

// The comparison with the scan folder's truth (ScanSummary's truth figures).
void EvaluateAgainstTruth(const scan::ScanFolder& folder, Model* m, ScanSummary* s);

// The report (pipeline/scan_report.cc).

// The left texture image with the measured markers circled (their outer ring) and numbered.
cv::Mat TextureWithMarkers(const cv::Mat& texture_left,
                           const std::vector<registration::ViewMarker>& markers,
                           const StereoRig& rig, int max_width_px);

// The absolute phase of the left camera, shrunk to max_width_px.
ReportImage PhasePicture(const std::string& name, const cv::Mat& phase_left, int max_width_px);

// A view's depth and (when measured) fringe modulation pictures.
std::vector<ReportImage> ViewPictures(const std::string& name, const OrganizedPointCloud& cloud);

// z opposite the views' mean viewing direction (the sensors look down at the part).
Rigid3d DisplayFromViews(const std::vector<Rigid3d>& world_from_sensor);

// The scan's report: summary, fused cloud and mesh, registration, calibration, views.
Report BuildReport(const std::filesystem::path& project, const ScanSummary& s,
                   const Calibration& cal, const std::vector<ViewResult>& views,
                   const Model& model);

}  // namespace fringe::pipeline::internal
