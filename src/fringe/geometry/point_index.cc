#include "fringe/geometry/point_index.h"

#include <nanoflann.hpp>

#include "fringe/util/error.h"

namespace fringe {

struct PointIndex::Impl {
  struct Adaptor {
    std::vector<Eigen::Vector3d> points;
    size_t kdtree_get_point_count() const { return points.size(); }
    double kdtree_get_pt(size_t i, size_t dim) const { return points[i][static_cast<int>(dim)]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
      return false;
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>,
                                                   Adaptor, 3, size_t>;
  explicit Impl(std::vector<Eigen::Vector3d> p)
      : adaptor{std::move(p)}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {}
  Adaptor adaptor;
  Tree tree;
};

PointIndex::PointIndex(std::vector<Eigen::Vector3d> points)
    : impl_(std::make_unique<Impl>(std::move(points))) {}
PointIndex::~PointIndex() = default;
PointIndex::PointIndex(PointIndex&&) noexcept = default;
PointIndex& PointIndex::operator=(PointIndex&&) noexcept = default;

size_t PointIndex::size() const { return impl_->adaptor.points.size(); }
const std::vector<Eigen::Vector3d>& PointIndex::points() const { return impl_->adaptor.points; }

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

}  // namespace fringe
