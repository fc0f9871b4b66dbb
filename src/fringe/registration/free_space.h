// Free-space (visibility) check of a relative pose between two views that carry their organized
// grids (marker-free registration).
//
// A view's grid says, for each of its pixels, how far the camera saw along that ray: space in
// front of the measured surface is empty. A pose that puts another view's points into that empty
// space is wrong, however well the rest overlaps: a pose slid along a plate lays the plate onto
// the plate, but the objects standing on it then float where the first view saw the plate
// through. The overlap and normal agreement (MeasureAgreement, icp.h) cannot see that: the slid
// object's points simply fall outside the overlap.
//
// For a seeded uniform sample of the source's points placed by target_from_source and projected
// into the target's grid (its fitted GridProjection, no camera model needed), the nearest slot
// and its 8 neighbours are read: a sample whose depth is less than the smallest valid depth
// there by more than tolerance_mm lies in the target's free space (the window absorbs the
// silhouettes, where one pixel sees the near surface and the next the far one). Samples that
// project outside the grid or onto holes say nothing (a hole may be a dark surface).
//
// Frames: each view's cloud in its own sensor frame; target_from_source. Millimetres.
// Thread safety: reentrant (parallel inside); deterministic for a seed.
#pragma once

#include <cstdint>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/registration/icp.h"

namespace fringe::registration {

struct FreeSpaceCheck {
  int projected = 0;  // samples that landed on valid slots of the target's grid
  int in_front = 0;   // of those, in the target's free space
  double fraction() const { return projected > 0 ? static_cast<double>(in_front) / projected : 0; }
};

// One result per pose. Throws fringe::Error when target_grid does not fit target (its slot list
// has another size than the cloud). An unfitted projection gives projected = 0.
std::vector<FreeSpaceCheck> CheckFreeSpace(const PointCloud& source, const PointCloud& target,
                                           const ViewGrid& target_grid,
                                           const std::vector<Rigid3d>& target_from_source,
                                           int samples, double tolerance_mm, uint64_t seed);

}  // namespace fringe::registration
