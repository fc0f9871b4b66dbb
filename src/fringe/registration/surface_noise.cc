#include "fringe/registration/surface_noise.h"

#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "fringe/geometry/point_index.h"
#include "fringe/util/error.h"

namespace fringe::registration {

double EstimateSurfaceNoiseMm(const PointCloud& cloud, int samples, int neighbours, uint64_t seed) {
  if (neighbours < 4 || samples < 1) {
    throw Error(util::StrCat("EstimateSurfaceNoiseMm: neighbours ", neighbours, " (>= 4), samples ",
                             samples, " (>= 1)"));
  }
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(cloud.size());
  for (const Eigen::Vector3d& p : cloud.points) {
    if (p.allFinite()) pts.push_back(p);
  }
  if (pts.size() < static_cast<size_t>(neighbours)) return 0;
  const PointIndex index(std::move(pts));
  const size_t n = index.size();
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  std::vector<size_t> at(samples);
  for (size_t& a : at) a = pick(rng);
  std::vector<double> rms(samples, 0.0);
  tbb::parallel_for(0, samples, [&](int s) {
    std::vector<size_t> idx;
    std::vector<double> d2;
    const size_t k = index.Nearest(index.point(at[s]), neighbours, &idx, &d2);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < k; ++i) mean += index.point(idx[i]);
    mean /= static_cast<double>(k);
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (size_t i = 0; i < k; ++i) {
      const Eigen::Vector3d d = index.point(idx[i]) - mean;
      cov += d * d.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    // Smallest eigenvalue = sum of squared plane distances; k - 3 degrees of freedom remain.
    rms[s] = std::sqrt(std::max(0.0, eig.eigenvalues()(0)) / static_cast<double>(k - 3));
  });
  std::nth_element(rms.begin(), rms.begin() + samples / 2, rms.end());
  return rms[samples / 2];
}

}  // namespace fringe::registration
