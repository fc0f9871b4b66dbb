// Detection of a calibration target (docs/formats.md, "Calibration target") in one grey image.
//
// Circular targets (rings, circles): dark blobs are found by contour analysis at several grey
// thresholds (so uneven lighting does not matter), each candidate is screened by its geometry
// (area, convexity, axis ratio, fit to an ellipse; for rings the concentric hole and its size
// ratio; the centre dot of distinct features), then measured with subpixel edge points
// (edges.h) and fitted ellipses (ellipse.h), rejected on a large fit residual. The grid is
// ordered by growing it from a seed with local affine predictions (robust to perspective, tilts
// up to 60 degrees and lens distortion): rings are seeded from the three distinct features, which
// fix origin and orientation even on partial boards; symmetric circle grids from any
// well-shaped neighbour triple and must be complete. A board that cannot be ordered
// unambiguously is refused (status kAmbiguous), never returned mis-ordered.
//
// Ring centres are the true projected centres from the two ellipses (ConcentricCentre); circle
// centres are ellipse centres (biased under perspective; calib.h corrects them from the
// estimated board pose). Edge points are kept so calibration can redo this on undistorted points.
//
// Symmetric circle grids have a 180-degree ambiguity (and 90 for square grids): the ordering
// chosen is the right-handed one (board seen from its front) whose column direction points most
// to the image's +x, so a stereo pair seeing the board alike orders it alike; a rotation of the
// board frame by 180 degrees in its own plane does not change intrinsics.
//
// Chessboards: OpenCV's findChessboardCorners + cornerSubPix first, findChessboardCornersSB
// (exhaustive, accuracy flag) when that finds no complete board. Asymmetric circle grids
// (CalibrationTarget's layout: odd rows shifted by half a spacing) are grown like symmetric ones
// and mapped onto the board by the unimodular basis change that covers it completely and
// right-handed; unique, so no orientation ambiguity. (OpenCV's findCirclesGrid expects its own
// asymmetric lattice, x = (2 col + row % 2) d, y = row d, and does not find this one.)
//
// Ring boards order their grid from the distinct (centre-dot) features by trying every
// assignment of the dotted rings found to the declared positions, so at most
// kMaxDistinctFeatures may be declared (more is an error saying so). A board whose every ring
// carries a dot, or none, declares "distinct_features": [] and is ordered like a symmetric grid
// (complete boards only, the orientation convention below).
//
// 16-bit images: the blob search runs on an 8-bit min-max scaled copy (contours need it), the
// subpixel edges on the full-precision image on the same 0-255 scale (edge thresholds are in
// those DN), so 16-bit captures keep their precision where it matters.
//
// Thread safety: DetectTarget is reentrant.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/calib/edges.h"
#include "fringe/calib/ellipse.h"
#include "fringe/geometry/calibration_target.h"

namespace fringe::calib {

// Most distinct (centre-dot) features a ring target may declare (see the header comment).
constexpr int kMaxDistinctFeatures = 8;

struct DetectionOptions {
  EdgeOptions edges;
  EllipseFitOptions ellipse_fit;
  double min_radius_px = 3.0;          // smallest feature semi-minor axis, px, > 0
  double max_radius_fraction = 0.3;    // largest semi-major axis / min(width, height), (0, 1]
  double min_axis_ratio = 0.15;        // semi-minor / semi-major (0.15: ~81 deg tilt), (0, 1]
  double min_convexity = 0.85;         // contour area / convex hull area, (0, 1]
  double max_fit_rms_px = 0.5;         // RMS orthogonal residual of the subpixel ellipse, px, > 0
  double min_edge_coverage = 0.6;      // fraction of edge samples found around a feature, (0, 1]
  double max_concentricity = 0.2;      // rings: ellipse-centre offset / outer semi-minor, > 0
  double ring_ratio_tolerance = 0.45;  // rings: relative tolerance on inner/outer size, (0, 1)
  int threshold_levels = 9;            // grey thresholds for blob candidates, [1, 64]
  double grid_tolerance = 0.3;  // max distance prediction -> feature / local spacing, (0, 0.5]
  double size_tolerance = 0.5;  // max relative size change between grid neighbours, (0, 1)
  void Check() const;
};

// One measured feature of the board.
struct FeatureObservation {
  int row = 0, col = 0;
  Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();  // see the header comment
  // Subpixel edge points (outer = outer boundary of the dark region; inner = rings' inner edge).
  std::vector<Eigen::Vector2d> outer_edge_px, inner_edge_px;
  Ellipse outer, inner;   // fitted to the edge points (inner only for rings)
  double fit_rms_px = 0;  // worst RMS residual of the fitted ellipses
};

struct RejectedCandidate {
  Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();
  std::string reason;
};

enum class DetectionStatus { kOk, kNotFound, kAmbiguous };
const char* DetectionStatusName(DetectionStatus s);

struct TargetDetection {
  DetectionStatus status = DetectionStatus::kNotFound;
  std::string message;
  int image_width = 0, image_height = 0;
  int num_candidates = 0;                    // circular blobs that passed the shape screening
  std::vector<FeatureObservation> features;  // ordered by (row, col)
  std::vector<RejectedCandidate> rejected;   // blobs not used, with the reason
  // What looks wrong with the target's declaration rather than the image (e.g. a ring board
  // declared as plain circles); empty when nothing does. Also appended to `message`.
  std::string warning;
  double seconds = 0;

  bool ok() const { return status == DetectionStatus::kOk; }
  std::string BriefReport() const;
};

// Detects `target` in a single-channel image (CV_8U or CV_16U). Throws fringe::Error when the
// target declares more than kMaxDistinctFeatures distinct features.
TargetDetection DetectTarget(const cv::Mat& gray, const CalibrationTarget& target,
                             const DetectionOptions& options = {});

// Concentric dark rings anywhere in an image, not ordered on any grid: a dark annulus around a
// bright disk whose radius is inner_to_outer_ratio times the annulus' outer radius (the sticky
// markers of multi-view registration). Same candidate search, subpixel edges, ellipse fits and
// pole-polar ring centres as DetectTarget's ring boards (the true projected centre of the
// circles' common centre for a planar ring, whatever the perspective), with the same rejection
// reasons. Features have row = col = -1.
struct RingDetection {
  std::vector<FeatureObservation> rings;    // largest first
  std::vector<RejectedCandidate> rejected;  // blobs that are not rings of this ratio, with why
  std::string BriefReport() const;
};
RingDetection DetectRings(const cv::Mat& gray, double inner_to_outer_ratio,
                          const DetectionOptions& options = {});

}  // namespace fringe::calib
