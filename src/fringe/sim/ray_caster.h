// Ray casting against a Scene: the objects' tessellations in one fringe::MeshIndex (Embree,
// hits recomputed in double precision on the hit triangle's plane), and sphere objects' hits
// moved onto their exact sphere, so points lie on the ray to ~1e-12 mm and on the true surface;
// the albedo at a hit, markers included. Frames: world (the scene's), millimetres.
// Thread safety: immutable after construction; all methods may run concurrently.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <vector>

#include "fringe/sim/scene.h"

namespace fringe::sim {

// First surface hit along a ray (world frame), double precision.
struct Hit {
  double t = 0;                                       // distance along the unit ray, mm
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    // world frame
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, world frame, geometric (not flipped)
  int object = -1;                                    // scene object index
  int triangle = -1;                                  // triangle index in the object's mesh
};

class RayCaster {
 public:
  // Copies the scene and builds the acceleration structure. Throws fringe::Error for an empty
  // scene or marker ids that are not 0, 1, 2, ... in order.
  explicit RayCaster(const Scene& scene);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  const Scene& scene() const;
  // First hit from `origin` along the UNIT direction `dir` beyond t_min (mm).
  std::optional<Hit> Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                          double t_min = 0) const;
  // True when a surface lies strictly between `from` and `to`.
  bool Occluded(const Eigen::Vector3d& from, const Eigen::Vector3d& to) const;
  // Albedo at a hit, markers included.
  double Albedo(const Hit& hit) const;

  // Batches (Embree ray streams, faster for coherent rays): rays from one origin along unit
  // directions; shadow rays from many points toward one point (1 = occluded).
  void CastBatch(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3d>& dirs,
                 std::vector<std::optional<Hit>>* hits) const;
  void OccludedBatch(const std::vector<Eigen::Vector3d>& from, const Eigen::Vector3d& to,
                     std::vector<uint8_t>* occluded) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fringe::sim
