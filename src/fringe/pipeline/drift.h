// Drift detection during every scan: does the rig calibration still
// describe the sensor that took this view? Decided from the view's own data, no artefact.
//
// What a view can show, and what it cannot:
//   - Stereo with vertical fringes: the matcher looks for the left pixel's phase along the
//     epipolar line of the CALIBRATED rig, so a right camera that has rotated or shifted since
//     is matched on the wrong line and still triangulates: the phase hides a vertical disparity.
//     The sticky markers are found in each image on their own, so their 2D centres show it: the
//     signed distance of each right centre to the epipolar line of its left centre is noise for
//     an intact rig and a systematic offset (pitch, vertical shift) or tilt (roll) for a drifted
//     one ("markers" below). The verdict looks at the systematic part (a plane fitted to the
//     signed distances over the image), not the RMS, and compares it with its own standard error
//     from the scatter about the plane: the centres' noise depends on the markers' size in pixels
//     (~0.03 px RMS on the reference rig, ~0.11 px at half its resolution), and a fixed threshold
//     high enough for small markers hides a roll the larger markers of a full-size rig show.
//   - A calibrated projector (stereo or camera + projector): a point triangulated by a drifted
//     pair lies off the plane of its projector column, so the mean signed difference between the
//     projector column of the point and its decoded phase moves away from zero ("calibrated
//     projector"). It sees what the markers cannot: a rotation about the vertical axis or a
//     change of the baseline's length changes the depth, not the vertical disparity. Its spatial
//     pattern sees more: a roll of a camera (about its optical axis) or a shift along it moves
//     the matched pixel along the epipolar line by an amount growing linearly with y (roll) or
//     x (scale), so the residual tilts across the image while its mean stays near zero; the
//     plane fitted to the residual over the image measures that tilt.
//   - Camera + projector with both fringe directions: each point is triangulated from three
//     measurements (camera pixel, projector column and row), and the round-trip residual of that
//     triangulation is the epipolar residual ("two-direction phase").
//   - Camera + projector with one direction, no markers in two images: nothing is redundant; the
//     view is not checked and the summary says so.
// Projector columns fitted to the scan itself (stereo without a calibrated projector) are not
// used: the fit adapts to the points the drifted rig made.
//
// The verdict names the evidence it rests on. Thresholds (DriftOptions): between the noise of an
// intact rig and the smallest drift to flag (bench_calibration_check measures both).
//
// Thread safety: the functions are reentrant.
#pragma once

#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/registration/markers.h"

namespace fringe::pipeline {

struct DriftOptions {
  // Markers seen by both cameras: the systematic part of their signed epipolar distances (RMS of
  // the plane a + b x + c y fitted to them over the image) above this, and significant (below),
  // is drift, pixels, > 0. A right camera pitched by 0.01 degrees gives 2500 px * 1.75e-4 =
  // 0.44 px on the reference rig, rolled by 0.01 degrees ~0.07 px. Intact: the systematic part
  // is up to 0.015 px on the full-size demo scan (markers' RMS 0.03 px) and 0.02-0.065 px on the
  // half-size test scan (RMS 0.09-0.13 px); bench_calibration_check.
  double max_epipolar_systematic_px = 0.03;
  int min_markers = 4;  // fewer markers in both images: no marker verdict, >= 2
  // The markers' systematic part must also exceed this many of its standard errors (from the
  // markers' scatter about the plane) to be drift, > 0: with ~12 px markers the centres' noise
  // alone gives a plane of up to 0.065 px, with ~25 px markers 0.015 px.
  double min_epipolar_significance = 3;
  // Calibrated projector: |mean signed column residual| of the points above this is drift,
  // projector pixels, > 0.
  double max_projector_bias_px = 0.05;
  // Calibrated projector: RMS of the plane a + b x + c y fitted to the points' column residuals
  // over the image above this is drift, projector pixels, > 0. A right camera rolled by 0.01
  // degrees tilts it by ~0.05 px across the reference rig's image (RMS ~0.02 px); an intact
  // rig's plane stays under 0.001 px (bench_calibration_check). Between the two, the threshold
  // leaves room for a real calibration's own error (a right camera orientation sigma of 0.0016
  // degrees: ~0.004 px).
  double max_projector_systematic_px = 0.01;
  int min_projector_points = 1000;  // fewer points: no projector verdict, >= 1
  // Camera + projector with both directions: RMS of the triangulation's round-trip residual
  // above this is drift, projector pixels, > 0 (the intact half-size test scan: 0.011 px).
  double max_two_direction_rms_px = 0.05;
  int max_samples = 50000;  // points sampled per view for the projector figures, >= 100
  void Check() const;
};

// One view's drift figures and verdict. NaN figures: that evidence was not available.
struct ViewDrift {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  // Epipolar residual: of the markers (stereo; signed, its mean beside the RMS) or of the
  // two-direction triangulation (camera + projector), pixels.
  double epipolar_rms_px = kNaN;
  double epipolar_mean_px = kNaN;
  double epipolar_systematic_px = kNaN;  // markers: RMS of the fitted plane (DriftOptions)
  // markers: the standard error of epipolar_systematic_px from the scatter about the plane
  double epipolar_systematic_sigma_px = kNaN;
  int epipolar_samples = 0;
  std::string epipolar_source;  // "markers", "two-direction phase", or empty
  // Projector consistency: projector column of the point minus its decoded phase, projector px.
  double projector_bias_px = kNaN, projector_rms_px = kNaN;
  // RMS of the plane fitted to the residuals over the image (the bias and tilt together), of the
  // points within 5 robust sigmas of the median residual (mismatches at edges are left out).
  double projector_systematic_px = kNaN;
  int projector_samples = 0;
  bool checked = false;               // some evidence was enough for a verdict
  bool drift = false;                 // a figure exceeded its threshold
  std::vector<std::string> evidence;  // what the verdict rests on (e.g. "markers (23)")
  std::string message;                // which figure exceeded, or why the view was not checked
};
nlohmann::json ToJson(const ViewDrift& s);

// Projector consistency from the view's points (left camera frame, on the left grid) and the
// left camera's absolute phase (projector columns, CV_32F, same grid): fills projector_*. No-op
// without a calibrated projector. Every k-th valid point, at most options.max_samples. Stereo
// only: in a camera + projector view the projector is what triangulates the point.
void MeasureProjectorConsistency(const StereoRig& rig, const OrganizedPointCloud& cloud,
                                 const cv::Mat& phase_left, const DriftOptions& options,
                                 ViewDrift* drift);
// Markers measured in both images (stereo): fills epipolar_* from their signed epipolar
// distances under `rig`.
void MeasureMarkerEpipolar(const StereoRig& rig,
                           const std::vector<registration::ViewMarker>& markers, ViewDrift* drift);
// Camera + projector with both directions: fills epipolar_* from the cloud's residual_px (the
// round trip of the two-direction triangulation).
void MeasureTwoDirectionResidual(const OrganizedPointCloud& cloud, ViewDrift* drift);
// Sets checked, drift, evidence and message from the figures.
void DecideDrift(const DriftOptions& options, ViewDrift* drift);

// RMS over the views' epipolar residuals, weighted by their samples; NaN without any.
double PooledEpipolarRmsPx(const std::vector<const ViewDrift*>& views);

}  // namespace fringe::pipeline
