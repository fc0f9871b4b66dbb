#include "fringe/registration/coarse.h"

#include <open3d/geometry/KDTreeFlann.h>
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/pipelines/registration/Registration.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "fringe/geometry/point_index.h"
#include "fringe/util/error.h"
#include "fringe/util/random.h"
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
  util::CheckOption(score_samples >= 10, o, "score_samples", score_samples, "must be >= 10");
  util::CheckOption(rescored_hypotheses >= 1, o, "rescored_hypotheses", rescored_hypotheses,
                    "must be >= 1");
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
  std::vector<int> distinctive;       // samples whose surface variation reaches the option's
  std::unique_ptr<PointIndex> index;  // over the samples: RANSAC scores against it as target
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
    impl->index = std::make_unique<PointIndex>(impl->samples->points_);
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

namespace {

// One RANSAC over feature correspondences (the algorithm of Open3D's
// RegistrationRANSACBasedOnCorrespondence: 3 random correspondences, the edge-length and
// distance checks, a point-to-point fit, the best fitness kept, the iteration count cut by the
// confidence), except for the scoring, which decides its cost: every hypothesis that passes the
// checks is scored on a seeded subsample of score_samples source samples (69 % of the
// marker-free registration of the 8-view scan was Open3D scoring each of them on all samples),
// and only the rescored_hypotheses best are scored on all of them, the best of those kept.
// Iterations run in parallel blocks, each from its own seed, reduced in order: the result does
// not depend on the thread count.
struct RansacResult {
  Eigen::Matrix4d transformation = Eigen::Matrix4d::Identity();
  double fitness = 0;  // fraction of all source samples within max_dist of a target sample
  double inlier_rmse = 0;
};

RansacResult Ransac(const std::vector<Eigen::Vector3d>& source, const PointIndex& target,
                    const o3reg::CorrespondenceSet& corres, double max_dist,
                    const CoarseOptions& options, uint64_t seed) {
  RansacResult out;
  const int nc = static_cast<int>(corres.size());
  if (nc < 3 || source.empty()) return out;
  constexpr double kEdgeSimilarity = 0.9;
  const double max_d2 = max_dist * max_dist;
  std::vector<uint32_t> all(source.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<uint32_t>(i);
  std::vector<uint32_t> sub = all;
  {
    std::mt19937_64 rng(util::MixSeed(seed, 0x5ca1ab1e));
    std::shuffle(sub.begin(), sub.end(), rng);
    sub.resize(std::min<size_t>(sub.size(), options.score_samples));
  }
  struct Score {
    int inliers = 0;
    double ss = 0;
    bool Better(const Score& o) const {
      return inliers > o.inliers || (inliers == o.inliers && ss < o.ss);
    }
  };
  const auto score = [&](const Eigen::Matrix4d& t, const std::vector<uint32_t>& which) {
    Score sc;
    const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
    const Eigen::Vector3d tr = t.topRightCorner<3, 1>();
    for (uint32_t i : which) {
      const double d2 = target.Nearest(r * source[i] + tr).second;
      if (d2 <= max_d2) {
        ++sc.inliers;
        sc.ss += d2;
      }
    }
    return sc;
  };
  struct Hypothesis {
    bool valid = false;
    Eigen::Matrix4d t;
    Score score;
  };
  std::vector<Hypothesis> best;  // the rescored_hypotheses best by subsample score, best first
  constexpr int kBlock = 1024;
  std::vector<Hypothesis> block(kBlock);
  double needed = options.max_ransac_iterations;
  for (int begin = 0; begin < std::min<double>(needed, options.max_ransac_iterations);
       begin += kBlock) {
    const int n = std::min(kBlock, options.max_ransac_iterations - begin);
    tbb::parallel_for(0, n, [&](int k) {
      Hypothesis& h = block[k];
      h.valid = false;
      std::mt19937_64 rng(util::MixSeed(seed, static_cast<uint64_t>(begin + k)));
      std::uniform_int_distribution<int> pick(0, nc - 1);
      int c[3] = {pick(rng), pick(rng), pick(rng)};
      if (c[0] == c[1] || c[0] == c[2] || c[1] == c[2]) return;
      Eigen::Matrix3d ps, pt;
      for (int m = 0; m < 3; ++m) {
        ps.col(m) = source[corres[c[m]](0)];
        pt.col(m) = target.point(corres[c[m]](1));
      }
      for (int a = 0; a < 3; ++a) {
        const int b = (a + 1) % 3;
        const double ds = (ps.col(a) - ps.col(b)).norm(), dt = (pt.col(a) - pt.col(b)).norm();
        if (ds < dt * kEdgeSimilarity || dt < ds * kEdgeSimilarity) return;
      }
      const Eigen::Matrix4d t = Eigen::umeyama(ps, pt, false);
      if (!t.allFinite()) return;
      for (int m = 0; m < 3; ++m) {
        const Eigen::Vector3d q = t.topLeftCorner<3, 3>() * ps.col(m) + t.topRightCorner<3, 1>();
        if ((q - pt.col(m)).squaredNorm() > max_d2) return;
      }
      h.t = t;
      h.score = score(t, sub);
      h.valid = h.score.inliers > 0;
    });
    for (int k = 0; k < n; ++k) {
      if (!block[k].valid) continue;
      if (static_cast<int>(best.size()) == options.rescored_hypotheses &&
          !block[k].score.Better(best.back().score)) {
        continue;
      }
      auto at = std::find_if(best.begin(), best.end(),
                             [&](const Hypothesis& b) { return block[k].score.Better(b.score); });
      best.insert(at, block[k]);
      if (static_cast<int>(best.size()) > options.rescored_hypotheses) best.pop_back();
    }
    if (!best.empty()) {
      const double f = static_cast<double>(best.front().score.inliers) / sub.size();
      const double miss = 1 - f * f * f;
      needed = miss <= 0 ? 0 : std::log(1 - options.ransac_confidence) / std::log(miss);
    }
  }
  Score top;
  for (const Hypothesis& h : best) {
    const Score sc = sub.size() == all.size() ? h.score : score(h.t, all);
    if (out.fitness == 0 || sc.Better(top)) {
      top = sc;
      out.transformation = h.t;
      out.fitness = static_cast<double>(sc.inliers) / source.size();
      out.inlier_rmse = sc.inliers > 0 ? std::sqrt(sc.ss / sc.inliers) : 0;
    }
  }
  return out;
}

}  // namespace

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
      const RansacResult res =
          Ransac(s->points_, *target.impl().index, corres, max_dist, options, seed + h);
      best_fitness = std::max(best_fitness, res.fitness);
      if (res.fitness <= 0) break;
      if (res.fitness >= options.min_fitness) {
        r.candidates.push_back(
            {Rigid3d::FromMatrix(res.transformation.topRows<3>()), res.fitness, res.inlier_rmse});
      }
      o3reg::CorrespondenceSet rest;
      for (const Eigen::Vector2i& c : corres) {
        const Eigen::Vector3d p = res.transformation.block<3, 3>(0, 0) * s->points_[c(0)] +
                                  res.transformation.block<3, 1>(0, 3);
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
