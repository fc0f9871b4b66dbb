// Best fit of a measured cloud to a reference mesh (inspection against CAD, `fringe evaluate
// --align`): point-to-plane ICP onto the mesh surface.
//
// Every iteration moves a sample of the cloud (normal-space order when the cloud has normals,
// icp.h; else seeded random) by the current mesh_from_cloud,
// finds each sample's closest surface point q (eval::MeshDistance: exact closest point on the
// triangles, not a vertex), and takes the direction from q to the point as the plane normal
// (the gradient of the distance to the surface: the face normal inside a face, the right one
// at edges and corners too, and no normals are needed on the cloud). Correspondences farther
// than the threshold are rejected, then the worst (1 - trim_fraction); one Gauss-Newton step of
// the 6 pose unknowns about the samples' centroid follows. Levels and threshold as in icp.h:
// more samples per level, the threshold fixed within a level and min(previous, shrink_factor x
// shrink_percentile of the residuals) after it, never below min_threshold_mm.
//
// Frames: cloud in its own frame, mesh in the reference frame; the result is mesh_from_cloud.
// Millimetres. Deterministic for a seed, independent of the thread count (parallel search,
// serial sums). Thread safety: reentrant.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fringe/eval/deviation.h"
#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/registration/icp.h"

namespace fringe::registration {

struct MeshAlignOptions {
  std::vector<int> points_per_level = {2000, 8000, 30000};  // samples, coarse to fine, >= 10
  int max_iterations_per_level = 30;                        // >= 1
  double initial_threshold_mm = 5.0;                        // > 0
  double min_threshold_mm = 0.02;                           // (0, initial_threshold_mm]
  double shrink_factor = 5.0;                               // > 0
  double shrink_percentile = 0.8;                           // (0, 1]
  // Kept fraction after the threshold, (0, 1]. 1: the reference is exact, and trimming the
  // largest residuals of a plane-dominated part removes the few wall points that hold its
  // sliding directions while they still carry the slide.
  double trim_fraction = 1.0;
  // Directions of the normal matrix below this fraction of the strongest are not moved (the
  // kept points do not constrain them), [0, 1).
  double degeneracy_ratio = 1e-6;
  double convergence_rotation_deg = 1e-5;    // > 0
  double convergence_translation_mm = 1e-5;  // > 0
  uint64_t seed = 1;
  void Check() const;
};

struct MeshAlignResult {
  IcpStatus status = IcpStatus::kNoOverlap;
  std::string message;
  Rigid3d mesh_from_cloud;
  std::vector<IcpLevelReport> levels;  // overlapping_pairs is 1 (the cloud and the mesh)
  double rms_mm = 0;                   // point-to-surface RMS of the kept samples at the end
  int correspondences = 0;             // kept samples at the end
  double seconds = 0;
  bool ok() const { return status == IcpStatus::kOk; }
  std::string BriefReport() const;
};

// Throws fringe::Error for bad options. An empty cloud, or one whose samples find no surface
// within the threshold, gives kNoOverlap with a message.
MeshAlignResult AlignToMesh(const PointCloud& cloud, const eval::MeshDistance& mesh,
                            const Rigid3d& mesh_from_cloud_start,
                            const MeshAlignOptions& options = {});

}  // namespace fringe::registration
