#include "fringe/registration/coarse.h"

#include <open3d/geometry/KDTreeFlann.h>
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/CorrespondenceChecker.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/utility/Random.h>

#include <algorithm>
#include <cmath>

#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::registration {

using util::StrCat;
namespace o3reg = open3d::pipelines::registration;

void CoarseOptions::Check() const {
  const char* o = "CoarseOptions";
  util::CheckOption(voxel_mm > 0, o, "voxel_mm", voxel_mm, "must be > 0");
  util::CheckOption(feature_radius_factor > 1, o, "feature_radius_factor", feature_radius_factor,
                    "must be > 1");
  util::CheckOption(max_ransac_iterations >= 1, o, "max_ransac_iterations", max_ransac_iterations,
                    "must be >= 1");
  util::CheckOption(ransac_confidence > 0 && ransac_confidence < 1, o, "ransac_confidence",
                    ransac_confidence, "must be in (0, 1)");
  util::CheckOption(min_fitness > 0 && min_fitness <= 1, o, "min_fitness", min_fitness,
                    "must be in (0, 1]");
  util::CheckOption(hypotheses >= 1, o, "hypotheses", hypotheses, "must be >= 1");
}

const char* ToString(CoarseStatus s) {
  switch (s) {
    case CoarseStatus::kOk:
      return "ok";
    case CoarseStatus::kTooFewPoints:
      return "too few points";
    case CoarseStatus::kNoAlignment:
      return "no alignment";
  }
  return "?";
}

std::string CoarseResult::BriefReport() const {
  std::string s = StrCat("coarse (FPFH + RANSAC): ", ToString(status), ", fitness ", fitness,
                         ", inlier rms ", inlier_rms_mm, " mm, ", source_samples, " / ",
                         target_samples, " samples, ", seconds, " s");
  if (!message.empty()) s += ": " + message;
  return s;
}

namespace {

constexpr int kFeatureNeighbours = 3;

std::shared_ptr<open3d::geometry::PointCloud> Downsampled(const PointCloud& c, double voxel) {
  open3d::geometry::PointCloud o;
  o.points_.reserve(c.size());
  for (size_t i = 0; i < c.size(); ++i) {
    if (!c.points[i].allFinite()) continue;
    if (c.has_normals() && !c.normals[i].allFinite()) continue;
    o.points_.push_back(c.points[i]);
    if (c.has_normals()) o.normals_.push_back(c.normals[i]);
  }
  auto d = o.VoxelDownSample(voxel);
  // FPFH needs normals; where the input had none (or lost them) estimate them from neighbours.
  if (!d->HasNormals()) {
    d->EstimateNormals(open3d::geometry::KDTreeSearchParamHybrid(3 * voxel, 30));
    d->OrientNormalsTowardsCameraLocation(Eigen::Vector3d::Zero());
  } else {
    d->NormalizeNormals();
  }
  return d;
}

}  // namespace

CoarseResult AlignCoarse(const PointCloud& source, const PointCloud& target,
                         const CoarseOptions& options) {
  options.Check();
  util::Timer timer;
  CoarseResult r;
  const auto s = Downsampled(source, options.voxel_mm);
  const auto t = Downsampled(target, options.voxel_mm);
  r.source_samples = static_cast<int>(s->points_.size());
  r.target_samples = static_cast<int>(t->points_.size());
  if (r.source_samples < 10 || r.target_samples < 10) {
    r.status = CoarseStatus::kTooFewPoints;
    r.message = "fewer than 10 samples after downsampling";
    r.seconds = timer.ElapsedSeconds();
    return r;
  }
  const double radius = options.feature_radius_factor * options.voxel_mm;
  const open3d::geometry::KDTreeSearchParamHybrid feature_param(radius, 100);
  const auto fs = o3reg::ComputeFPFHFeature(*s, feature_param);
  const auto ft = o3reg::ComputeFPFHFeature(*t, feature_param);
  const double max_dist = 1.5 * options.voxel_mm;
  const o3reg::CorrespondenceCheckerBasedOnEdgeLength edge(0.9);
  const o3reg::CorrespondenceCheckerBasedOnDistance dist(max_dist);
  // Feature correspondences: each source sample to its kFeatureNeighbours nearest target
  // features (several, so that every copy of a repeated structure is among them).
  o3reg::CorrespondenceSet corres;
  {
    const open3d::geometry::KDTreeFlann tree(*ft);
    std::vector<int> idx;
    std::vector<double> d2;
    for (int i = 0; i < static_cast<int>(fs->data_.cols()); ++i) {
      const Eigen::VectorXd f = fs->data_.col(i);
      const int found = tree.SearchKNN(f, kFeatureNeighbours, idx, d2);
      for (int k = 0; k < found; ++k) corres.emplace_back(i, idx[k]);
    }
  }
  // Sequential RANSAC: after each hypothesis its inlier correspondences are removed and the
  // rest searched again, so the later candidates are the best DIFFERENT alignments (the other
  // copies of a symmetric scene, or chance fits when the first is unique).
  double best_fitness = 0;
  for (int h = 0; h < options.hypotheses && corres.size() >= 3; ++h) {
    open3d::utility::random::Seed(static_cast<int>((options.seed + h) & 0x7fffffff));
    const o3reg::RegistrationResult res = o3reg::RegistrationRANSACBasedOnCorrespondence(
        *s, *t, corres, max_dist, o3reg::TransformationEstimationPointToPoint(false), 3,
        {edge, dist},
        o3reg::RANSACConvergenceCriteria(options.max_ransac_iterations, options.ransac_confidence));
    best_fitness = std::max(best_fitness, res.fitness_);
    if (res.fitness_ <= 0) break;
    if (res.fitness_ >= options.min_fitness) {
      r.candidates.push_back(
          {Rigid3d::FromMatrix(res.transformation_.topRows<3>()), res.fitness_, res.inlier_rmse_});
    }
    o3reg::CorrespondenceSet rest;
    for (const Eigen::Vector2i& c : corres) {
      const Eigen::Vector3d p = res.transformation_.block<3, 3>(0, 0) * s->points_[c(0)] +
                                res.transformation_.block<3, 1>(0, 3);
      if ((p - t->points_[c(1)]).norm() > max_dist) rest.push_back(c);
    }
    if (rest.size() == corres.size()) break;
    corres.swap(rest);
  }
  std::stable_sort(
      r.candidates.begin(), r.candidates.end(),
      [](const CoarseCandidate& a, const CoarseCandidate& b) { return a.fitness > b.fitness; });
  r.seconds = timer.ElapsedSeconds();
  if (r.candidates.empty()) {
    r.fitness = best_fitness;
    r.status = CoarseStatus::kNoAlignment;
    r.message = StrCat("best RANSAC fitness ", best_fitness, " is below ", options.min_fitness);
    return r;
  }
  r.fitness = r.candidates.front().fitness;
  r.inlier_rms_mm = r.candidates.front().inlier_rms_mm;
  r.target_from_source = r.candidates.front().target_from_source;
  r.status = CoarseStatus::kOk;
  return r;
}

}  // namespace fringe::registration
