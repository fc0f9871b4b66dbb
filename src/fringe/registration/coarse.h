// Marker-free coarse alignment: FPFH features from Open3D + RANSAC (Rusu et al., "Fast Point
// Feature Histograms (FPFH) for 3D registration", ICRA 2009), for views that share fewer than
// three reliable markers with the map and for clouds without markers.
//
// Both clouds are voxel-downsampled (voxel_mm), FPFH features computed within
// feature_radius_factor x voxel, and RANSAC run with edge-length and distance checkers; a
// candidate is kept when its fitness (fraction of source samples within 1.5 voxels of the
// target) reaches min_fitness.
//
// Hypotheses: every source sample is paired with its 3 nearest target features (and, in a
// second pass, every distinctive source sample with the 3 nearest distinctive target features;
// see distinctive_variation), and RANSAC
// (see below) runs `hypotheses` times in sequence, each
// time on the correspondences the earlier alignments did not explain. The candidates are
// therefore the best alignment and the best DIFFERENT ones: on a scene with a symmetry (a square
// box on a plate) the second is another copy and fits as well as the first, which no single
// fitness reveals. RegisterViews refines and compares them and refuses such a view rather than
// place it confidently wrong.
//
// RANSAC is Open3D's algorithm (RegistrationRANSACBasedOnCorrespondence: 3 correspondences,
// edge-length and distance checks, point-to-point fit, confidence-cut iteration count) run by
// coarse.cc itself so that a hypothesis is scored on a subsample of the source (score_samples)
// and only the best few on all of it: scoring every hypothesis on all samples was most of the
// marker-free registration's time.
//
// Determinism: every iteration draws from its own seed (util::MixSeed(seed, iteration)) and the
// parallel blocks are reduced in order: the same result for any thread count.
//
// Frames: source and target clouds in their own frames; result target_from_source. mm.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"

namespace fringe::registration {

struct CoarseOptions {
  double voxel_mm = 2.0;               // downsampling voxel, > 0
  double feature_radius_factor = 5.0;  // FPFH radius / voxel, > 1
  int max_ransac_iterations = 100000;  // >= 1
  double ransac_confidence = 0.999;    // (0, 1)
  double min_fitness = 0.2;            // accepted fraction of matched source samples, (0, 1]
  int hypotheses = 4;                  // sequential RANSAC runs (see above), >= 1
  // Each hypothesis that passes the checks is scored on this many seeded source samples, >= 10;
  // the rescored_hypotheses best (>= 1) are scored again on all samples and the best kept.
  int score_samples = 1000;
  int rescored_hypotheses = 8;
  // A second sequential RANSAC (hypotheses more runs) among the distinctive samples only: those
  // whose surface variation (smallest eigenvalue / sum, over the feature radius; 0 on a plane)
  // reaches this, when they are fewer than half of either cloud's samples. On a scene dominated
  // by a plate, the plate's alike features outvote the few objects that fix the pose. [0, 1/3);
  // 0: no second pass.
  double distinctive_variation = 0.005;
  uint64_t seed = 1;
  void Check() const;
};

enum class CoarseStatus { kOk, kTooFewPoints, kNoAlignment };
const char* ToString(CoarseStatus s);

struct CoarseCandidate {
  Rigid3d target_from_source;
  double fitness = 0;
  double inlier_rms_mm = 0;
};

struct CoarseResult {
  CoarseStatus status = CoarseStatus::kNoAlignment;
  std::string message;
  // The sequential RANSAC's alignments with fitness >= min_fitness, best fitness first; the
  // first is target_from_source.
  std::vector<CoarseCandidate> candidates;
  Rigid3d target_from_source;
  double fitness = 0;  // fraction of downsampled source points with a close target point
  double inlier_rms_mm = 0;
  int source_samples = 0, target_samples = 0;
  double seconds = 0;
  bool ok() const { return status == CoarseStatus::kOk; }
  std::string BriefReport() const;
};

CoarseResult AlignCoarse(const PointCloud& source, const PointCloud& target,
                         const CoarseOptions& options = {});

// A cloud's downsampled samples and FPFH features (options.voxel_mm, feature_radius_factor),
// computed once per view when one view is aligned with several (RegisterViews' pairwise
// candidates): AlignCoarse(source, target) = AlignCoarse(Prepare(source), Prepare(target)).
// Immutable once made; may be shared between threads.
class CoarseFeatures {
 public:
  CoarseFeatures(const PointCloud& cloud, const CoarseOptions& options);
  ~CoarseFeatures();
  int samples() const;
  double voxel_mm() const { return voxel_mm_; }
  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  std::shared_ptr<const Impl> impl_;
  double voxel_mm_ = 0;
};
// Throws fringe::Error when the two were prepared with different voxels.
CoarseResult AlignCoarse(const CoarseFeatures& source, const CoarseFeatures& target,
                         const CoarseOptions& options = {});

}  // namespace fringe::registration
