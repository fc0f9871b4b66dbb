// Closest-point and ray queries on triangle meshes: one Embree 3 BVH over one or more meshes,
// every answer recomputed in double precision.
//
// Closest points come from Embree's point query (rtcPointQuery) with an exact closest-point-on-
// triangle test (Ericson, "Real-Time Collision Detection", 5.1.5). The sign of a distance is that
// of (p - q) . n with n the angle-weighted pseudo-normal of the closest feature (face, edge or
// vertex; Baerentzen & Aanaes, "Signed distance computation using the angle weighted
// pseudonormal", IEEE TVCG 2005): positive outside (on the side the counter-clockwise triangles
// face), negative inside, correct at edges and corners too.
//
// Rays are intersected by Embree with its float triangles; the hit is then recomputed on the hit
// triangle's plane in double precision, so points lie on the ray to ~1e-12 mm.
//
// Every index shares one Embree device (a device holds Embree's thread pool and allocators;
// one per index cost a thread pool per mesh).
//
// Frames and units: those of the meshes (millimetres in fringe).
// Thread safety: immutable after construction; every method may run concurrently.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "fringe/geometry/triangle_mesh.h"

namespace fringe {

// First surface hit along a ray.
struct MeshHit {
  double t = 0;                                       // distance along the unit ray
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    // on the hit triangle's plane
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, geometric (not flipped)
  int mesh = -1;                                      // index of the mesh in the index
  int triangle = -1;                                  // triangle index in that mesh
};

// How much effort the BVH build spends: kHigh (spatial splits) pays off for the many coherent
// rays of a renderer; kMedium builds faster, for closest-point queries.
enum class BvhQuality { kMedium, kHigh };

class MeshIndex {
 public:
  // Throws fringe::Error when there is no triangle in all, for out-of-range indices or non-
  // finite vertices. Only vertices and triangles are used (normals come from the triangle order).
  explicit MeshIndex(TriangleMesh mesh, BvhQuality quality = BvhQuality::kMedium);
  explicit MeshIndex(std::vector<TriangleMesh> meshes, BvhQuality quality = BvhQuality::kMedium);
  ~MeshIndex();
  MeshIndex(const MeshIndex&) = delete;
  MeshIndex& operator=(const MeshIndex&) = delete;

  int mesh_count() const;
  // Mesh i's vertices and triangles as given (its normals and colours are not kept).
  const TriangleMesh& mesh(int i) const;

  // Signed distance of p to the nearest surface of any mesh; the closest surface point in
  // *closest when given. NaN when no surface point is within max_distance.
  double SignedDistance(const Eigen::Vector3d& p, double max_distance = 1e30,
                        Eigen::Vector3d* closest = nullptr) const;

  // First hit from `origin` along the UNIT direction `dir` beyond t_min.
  std::optional<MeshHit> Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                              double t_min = 0) const;
  // True when a surface lies strictly between `from` and `to`.
  bool Occluded(const Eigen::Vector3d& from, const Eigen::Vector3d& to) const;

  // Batches (Embree ray streams, faster for coherent rays): rays from one origin along unit
  // directions; shadow rays from many points toward one point (1 = occluded).
  void CastBatch(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3d>& dirs,
                 std::vector<std::optional<MeshHit>>* hits) const;
  void OccludedBatch(const std::vector<Eigen::Vector3d>& from, const Eigen::Vector3d& to,
                     std::vector<uint8_t>* occluded) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fringe
