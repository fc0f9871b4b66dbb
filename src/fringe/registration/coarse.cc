#include "fringe/registration/coarse.h"

#include <open3d/geometry/KDTreeFlann.h>
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/CorrespondenceChecker.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/utility/Random.h>

#include <Eigen/Eigenvalues>
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
  util::CheckOption(distinctive_variation >= 0 && distinctive_variation < 1.0 / 3, o,
                    "distinctive_variation", distinctive_variation, "must be in [0, 1/3)");
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

struct CoarseFeatures::Impl {
  std::shared_ptr<open3d::geometry::PointCloud> samples;
  std::shared_ptr<o3reg::Feature> features;
  std::vector<int> distinctive;  // samples whose surface variation reaches the option's
};

namespace {
// Surface variation lambda_min / (lambda_0 + lambda_1 + lambda_2) of each sample's neighbours
// within `radius` (Pauly et al. 2002): 0 on a plane, 1/3 for isotropic scatter.
std::vector<double> SurfaceVariation(const open3d::geometry::PointCloud& c, double radius) {
  const open3d::geometry::KDTreeFlann tree(c);
  std::vector<double> out(c.points_.size(), 0.0);
  std::vector<int> idx;
  std::vector<double> d2;
  for (size_t i = 0; i < c.points_.size(); ++i) {
    const int found = tree.SearchHybrid(c.points_[i], radius, 100, idx, d2);
    if (found < 5) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int k = 0; k < found; ++k) mean += c.points_[idx[k]];
    mean /= found;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (int k = 0; k < found; ++k) {
      const Eigen::Vector3d d = c.points_[idx[k]] - mean;
      cov += d * d.transpose();
    }
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvalues();
    const double sum = ev.sum();
    out[i] = sum > 0 ? std::max(0.0, ev(0)) / sum : 0.0;
  }
  return out;
}
}  // namespace

CoarseFeatures::CoarseFeatures(const PointCloud& cloud, const CoarseOptions& options)
    : voxel_mm_(options.voxel_mm) {
  options.Check();
  auto impl = std::make_shared<Impl>();
  impl->samples = Downsampled(cloud, options.voxel_mm);
  if (impl->samples->points_.size() >= 10) {
    const double radius = options.feature_radius_factor * options.voxel_mm;
    impl->features = o3reg::ComputeFPFHFeature(
        *impl->samples, open3d::geometry::KDTreeSearchParamHybrid(radius, 100));
    if (options.distinctive_variation > 0) {
      const std::vector<double> var = SurfaceVariation(*impl->samples, radius);
      for (size_t i = 0; i < var.size(); ++i) {
        if (var[i] >= options.distinctive_variation)
          impl->distinctive.push_back(static_cast<int>(i));
      }
    }
  }
  impl_ = std::move(impl);
}
CoarseFeatures::~CoarseFeatures() = default;
int CoarseFeatures::samples() const { return static_cast<int>(impl_->samples->points_.size()); }

CoarseResult AlignCoarse(const PointCloud& source, const PointCloud& target,
                         const CoarseOptions& options) {
  options.Check();
  util::Timer timer;
  CoarseResult r =
      AlignCoarse(CoarseFeatures(source, options), CoarseFeatures(target, options), options);
  r.seconds = timer.ElapsedSeconds();
  return r;
}

CoarseResult AlignCoarse(const CoarseFeatures& source, const CoarseFeatures& target,
                         const CoarseOptions& options) {
  options.Check();
  if (source.voxel_mm() != target.voxel_mm()) {
    throw Error(StrCat("AlignCoarse: source features were prepared with voxel ", source.voxel_mm(),
                       " mm, target features with ", target.voxel_mm(), " mm"));
  }
  util::Timer timer;
  CoarseResult r;
  const auto& s = source.impl().samples;
  const auto& t = target.impl().samples;
  r.source_samples = static_cast<int>(s->points_.size());
  r.target_samples = static_cast<int>(t->points_.size());
  if (r.source_samples < 10 || r.target_samples < 10) {
    r.status = CoarseStatus::kTooFewPoints;
    r.message = "fewer than 10 samples after downsampling";
    r.seconds = timer.ElapsedSeconds();
    return r;
  }
  const auto& fs = source.impl().features;
  const auto& ft = target.impl().features;
  const double max_dist = 1.5 * options.voxel_mm;
  const o3reg::CorrespondenceCheckerBasedOnEdgeLength edge(0.9);
  const o3reg::CorrespondenceCheckerBasedOnDistance dist(max_dist);
  // Feature correspondences: each source sample to its kFeatureNeighbours nearest target
  // features (several, so that every copy of a repeated structure is among them), among the
  // given samples only.
  const auto correspondences = [&](const std::vector<int>* src, const std::vector<int>* tgt) {
    o3reg::CorrespondenceSet corres;
    o3reg::Feature sub;
    const o3reg::Feature* target_features = ft.get();
    if (tgt) {
      sub.Resize(ft->Dimension(), static_cast<int>(tgt->size()));
      for (size_t k = 0; k < tgt->size(); ++k) sub.data_.col(k) = ft->data_.col((*tgt)[k]);
      target_features = &sub;
    }
    const open3d::geometry::KDTreeFlann tree(*target_features);
    std::vector<int> idx;
    std::vector<double> d2;
    const int n = src ? static_cast<int>(src->size()) : static_cast<int>(fs->data_.cols());
    for (int k = 0; k < n; ++k) {
      const int i = src ? (*src)[k] : k;
      const Eigen::VectorXd f = fs->data_.col(i);
      const int found = tree.SearchKNN(f, kFeatureNeighbours, idx, d2);
      for (int m = 0; m < found; ++m) corres.emplace_back(i, tgt ? (*tgt)[idx[m]] : idx[m]);
    }
    return corres;
  };
  // Sequential RANSAC: after each hypothesis its inlier correspondences are removed and the
  // rest searched again, so the later candidates are the best DIFFERENT alignments (the other
  // copies of a symmetric scene, or chance fits when the first is unique).
  double best_fitness = 0;
  const auto sequential = [&](o3reg::CorrespondenceSet corres, uint64_t seed) {
    for (int h = 0; h < options.hypotheses && corres.size() >= 3; ++h) {
      open3d::utility::random::Seed(static_cast<int>((seed + h) & 0x7fffffff));
      const o3reg::RegistrationResult res = o3reg::RegistrationRANSACBasedOnCorrespondence(
          *s, *t, corres, max_dist, o3reg::TransformationEstimationPointToPoint(false), 3,
          {edge, dist},
          o3reg::RANSACConvergenceCriteria(options.max_ransac_iterations,
                                           options.ransac_confidence));
      best_fitness = std::max(best_fitness, res.fitness_);
      if (res.fitness_ <= 0) break;
      if (res.fitness_ >= options.min_fitness) {
        r.candidates.push_back({Rigid3d::FromMatrix(res.transformation_.topRows<3>()), res.fitness_,
                                res.inlier_rmse_});
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
  };
  sequential(correspondences(nullptr, nullptr), options.seed);
  // Again among the distinctive samples only (see CoarseOptions::distinctive_variation), when
  // they are a minority: on a plate-dominated scene the plate's many alike features outvote
  // the few objects that fix the pose, and no hypothesis of the first pass is the right one.
  const std::vector<int>& ds = source.impl().distinctive;
  const std::vector<int>& dt = target.impl().distinctive;
  if (ds.size() >= 10 && dt.size() >= 10 &&
      (ds.size() < 0.5 * s->points_.size() || dt.size() < 0.5 * t->points_.size())) {
    sequential(correspondences(&ds, &dt), options.seed + options.hypotheses);
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
