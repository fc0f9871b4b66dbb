// The projector's columns estimated from a stereo scan itself, for the projector-consistency
// check of stereo matching when the rig has no calibrated projector.
//
// Why: phase alone cannot tell some false stereo matches from true ones (at occlusions the
// same phase occurs once in each camera's row on different surfaces); the triangulated point
// of such a match does not lie on the projector ray of its phase. With a calibrated projector
// the matcher checks that (MatchingOptions::max_projector_error_px). A stereo rig calibrated
// from board images has no projector, yet every stereo view measures the projector: each
// triangulated point X (left camera frame) is lit by the projector column given by its left
// absolute phase u. Over a scan (points at many depths, the projector fixed in the sensor
// frame) these pairs determine the column map exactly, up to the phase noise.
//
// Model: the first and third rows of a pinhole projector's 3 x 4 projection matrix (a 1D
// projective camera), u = (a . [X; 1]) / (c . [X; 1]); 7 degrees of freedom, no distortion.
// Fit: direct linear transform on Hartley-normalised data (points centred and scaled to mean
// distance sqrt(3), columns to mean deviation 1), solved as the smallest eigenvector of the
// 8 x 8 normal matrix, re-weighted by 1 / (c . [X; 1]) so that it minimises the column error
// in projector pixels (not the algebraic error), and trimmed: each round keeps the pairs within
// max(max_error_px / 4, 4 x 1.4826 x median error) of the previous fit, so false matches do not
// pull it. Accepted only when the points span three dimensions (coplanar points leave a and c
// undetermined off the plane), enough pairs fit within max_error_px and their RMS is small: a
// projector with noticeable lens distortion is refused (reported), never half-used.
//
// Frames: points in the left camera (sensor) frame, mm; columns in projector pixels (the
// scheme's absolute phase unit). Thread safety: free functions, reentrant; deterministic.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"

namespace fringe::stereo {

struct ProjectorColumnModel {
  Eigen::Matrix<double, 2, 4> rows = Eigen::Matrix<double, 2, 4>::Zero();  // a, c (raw units)
  // Column lighting the point, projector pixels; NaN when the point is at or behind the
  // projector's plane (c . [X; 1] <= 0 after the sign convention of the fit).
  double Column(const Eigen::Vector3d& p_in_left) const;
};

struct ProjectorColumnFitOptions {
  int min_points = 1000;             // pairs needed, >= 8
  int rounds = 6;                    // trimming / re-weighting rounds, [1, 20]
  double max_error_px = 1.0;         // inlier tolerance, projector pixels, > 0
  double max_rms_px = 0.25;          // largest accepted RMS of the inliers, px, > 0
  double min_inlier_fraction = 0.9;  // of the pairs, (0, 1]
  // Smallest / largest standard deviation of the points along their principal axes: below,
  // the points are too close to a plane to fix the model, (0, 1).
  double min_thickness = 0.02;
  void Check() const;
};

struct ProjectorColumnFit {
  bool ok = false;      // accepted (the model may be used)
  std::string message;  // why not, or a one-line summary
  ProjectorColumnModel model;
  int num_points = 0, num_inliers = 0;
  double rms_px = 0;     // inliers' RMS column error
  double thickness = 0;  // as min_thickness
};

// Throws fringe::Error when the sizes differ or an option is out of range; data problems (too
// few points, planar points, a poor fit) come back as ok = false with the reason.
ProjectorColumnFit FitProjectorColumns(const std::vector<Eigen::Vector3d>& points_in_left,
                                       const std::vector<double>& columns,
                                       const ProjectorColumnFitOptions& options = {});

// Pairs (point, left absolute phase) of every `stride`-th valid point of an organized cloud on
// the left grid whose phase is finite; phase is CV_32F of the cloud's size.
void SampleProjectorColumns(const OrganizedPointCloud& cloud, const cv::Mat& phase_left, int stride,
                            std::vector<Eigen::Vector3d>* points, std::vector<double>* columns);

// Marks invalid every point whose predicted column differs from its left phase by more than
// max_error_px (or whose phase is not finite); returns how many were removed.
int RejectByProjectorColumns(const ProjectorColumnModel& model, const cv::Mat& phase_left,
                             double max_error_px, OrganizedPointCloud* cloud);

}  // namespace fringe::stereo
