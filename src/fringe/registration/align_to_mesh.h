// Best fit of a measured cloud to a reference mesh (inspection against CAD, `fringe evaluate
// --align`): point-to-plane ICP onto the mesh surface.
//
// Every iteration moves a sample of the cloud (normal-space order when the cloud has normals,
// icp.h; else seeded random) by the current mesh_from_cloud,
// finds each sample's closest surface point q (MeshIndex: exact closest point on the
// triangles, not a vertex), and takes the direction from q to the point as the plane normal
// (the gradient of the distance to the surface: the face normal inside a face, the right one
// at edges and corners too, and no normals are needed on the cloud). Correspondences farther
// than the threshold are rejected, then the worst (1 - trim_fraction); one Gauss-Newton step of
// the 6 pose unknowns about the samples' centroid follows. Levels, threshold, step and
// convergence: icp_schedule.h, the same schedule as the view-to-view ICP.
//
// Frames: cloud in its own frame, mesh in the reference frame; the result is mesh_from_cloud.
// Millimetres. Deterministic for a seed, independent of the thread count (parallel search,
// serial sums). Thread safety: reentrant.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fringe/geometry/mesh_index.h"
#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/registration/icp.h"
#include "fringe/registration/icp_schedule.h"

namespace fringe::registration {

// The schedule is icp_schedule.h's, the one every ICP of the project runs; the defaults differ
// where the reference differs: a mesh is exact, so the threshold may shrink further, the
// convergence limits are tighter and more iterations are allowed.
struct MeshAlignOptions : IcpSchedule {
  MeshAlignOptions() {
    max_iterations_per_level = 30;
    min_threshold_mm = 0.02;
    degeneracy_ratio = 1e-6;
    convergence_rotation_deg = 1e-5;
    convergence_translation_mm = 1e-5;
  }
  // Kept fraction after the threshold, (0, 1]. 1: the reference is exact, and trimming the
  // largest residuals of a plane-dominated part removes the few wall points that hold its
  // sliding directions while they still carry the slide.
  double trim_fraction = 1.0;
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
MeshAlignResult AlignToMesh(const PointCloud& cloud, const MeshIndex& mesh,
                            const Rigid3d& mesh_from_cloud_start,
                            const MeshAlignOptions& options = {});

}  // namespace fringe::registration
