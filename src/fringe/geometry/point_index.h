// Nearest-neighbour queries over a fixed set of 3D points: a nanoflann k-d tree (Debian
// libnanoflann-dev; its build is ~3x faster than Open3D's FLANN tree on a fused scan, which
// matters for the meshing of a million-point cloud).
//
// Frames and units: those of the points.
// Thread safety: const methods may run concurrently.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace fringe {

class PointIndex {
 public:
  explicit PointIndex(std::vector<Eigen::Vector3d> points);
  // An index over `count` points the caller owns and keeps alive and unchanged while the index
  // is used (no copy: the registration indexes every view's cloud in place).
  PointIndex(const Eigen::Vector3d* points, size_t count);
  ~PointIndex();
  PointIndex(PointIndex&&) noexcept;
  PointIndex& operator=(PointIndex&&) noexcept;
  PointIndex(const PointIndex&) = delete;
  PointIndex& operator=(const PointIndex&) = delete;

  size_t size() const;
  const Eigen::Vector3d& point(size_t i) const;

  // Index of the nearest point and its squared distance; throws fringe::Error on an empty set.
  std::pair<size_t, double> Nearest(const Eigen::Vector3d& p) const;
  // The min(k, size()) nearest points, nearest first: indices and squared distances; returns how
  // many were found.
  size_t Nearest(const Eigen::Vector3d& p, size_t k, std::vector<size_t>* indices,
                 std::vector<double>* squared_distances) const;
  // Index of the nearest point within sqrt(radius_sq) of p, or -1 when none is. The search
  // starts with the radius as its worst distance, so branches beyond it are pruned: a query
  // outside the points' surface (most of ICP's samples outside two views' overlap) costs a few
  // node visits instead of a full descent. Of equally near points, the first the search meets.
  int64_t NearestWithin(const Eigen::Vector3d& p, double radius_sq) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fringe
