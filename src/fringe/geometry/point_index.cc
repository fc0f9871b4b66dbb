#include "fringe/geometry/point_index.h"

#include <nanoflann.hpp>

#include "fringe/util/error.h"

namespace fringe {

struct PointIndex::Impl {
  struct Adaptor {
    std::vector<Eigen::Vector3d> owned;  // empty when the points are the caller's
    const Eigen::Vector3d* points = nullptr;
    size_t count = 0;
    size_t kdtree_get_point_count() const { return count; }
    double kdtree_get_pt(size_t i, size_t dim) const { return points[i][static_cast<int>(dim)]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
      return false;
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>,
                                                   Adaptor, 3, size_t>;
  explicit Impl(Adaptor a)
      : adaptor(std::move(a)), tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {}
  static Adaptor Owning(std::vector<Eigen::Vector3d> p) {
    Adaptor a;
    a.owned = std::move(p);
    a.points = a.owned.data();
    a.count = a.owned.size();
    return a;
  }
  Adaptor adaptor;
  Tree tree;
};

// A result set for nanoflann: the nearest point closer than its starting worst distance.
struct NearestWithinRadius {
  explicit NearestWithinRadius(double radius_sq) : d2(radius_sq) {}
  double d2;
  size_t index = 0;
  bool found = false;
  size_t size() const { return found ? 1 : 0; }
  bool full() const { return found; }
  bool addPoint(double dist, size_t i) {
    if (dist < d2) {
      d2 = dist;
      index = i;
      found = true;
    }
    return true;
  }
  double worstDist() const { return d2; }
};

PointIndex::PointIndex(std::vector<Eigen::Vector3d> points)
    : impl_(std::make_unique<Impl>(Impl::Owning(std::move(points)))) {}
PointIndex::PointIndex(const Eigen::Vector3d* points, size_t count)
    : impl_(std::make_unique<Impl>(Impl::Adaptor{{}, points, count})) {}
PointIndex::~PointIndex() = default;
PointIndex::PointIndex(PointIndex&&) noexcept = default;
PointIndex& PointIndex::operator=(PointIndex&&) noexcept = default;

size_t PointIndex::size() const { return impl_->adaptor.count; }
const Eigen::Vector3d& PointIndex::point(size_t i) const { return impl_->adaptor.points[i]; }

std::pair<size_t, double> PointIndex::Nearest(const Eigen::Vector3d& p) const {
  if (size() == 0) throw Error("PointIndex::Nearest: no points");
  size_t index = 0;
  double d2 = 0;
  impl_->tree.knnSearch(p.data(), 1, &index, &d2);
  return {index, d2};
}

size_t PointIndex::Nearest(const Eigen::Vector3d& p, size_t k, std::vector<size_t>* indices,
                           std::vector<double>* squared_distances) const {
  k = std::min(k, size());
  indices->resize(k);
  squared_distances->resize(k);
  if (k == 0) return 0;
  const size_t found =
      impl_->tree.knnSearch(p.data(), k, indices->data(), squared_distances->data());
  indices->resize(found);
  squared_distances->resize(found);
  return found;
}

int64_t PointIndex::NearestWithin(const Eigen::Vector3d& p, double radius_sq) const {
  NearestWithinRadius result(radius_sq);
  impl_->tree.findNeighbors(result, p.data(), nanoflann::SearchParams());
  return result.found ? static_cast<int64_t>(result.index) : -1;
}

}  // namespace fringe
