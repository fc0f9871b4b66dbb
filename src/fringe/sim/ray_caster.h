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

#include "fringe/geometry/mesh_index.h"
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
  // Albedo at a hit, markers included.
  double Albedo(const Hit& hit) const;

  // Rays from one origin along unit directions as one Embree ray stream (faster for coherent
  // rays).
  void CastBatch(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3d>& dirs,
                 std::vector<std::optional<Hit>>* hits) const;
  // The objects' tessellations (mesh i = object i), for occlusion (shadow rays need no exact
  // surface) and closest points.
  const MeshIndex& index() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fringe::sim
