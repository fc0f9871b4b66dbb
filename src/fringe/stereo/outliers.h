// Outlier removal for organized (image-grid) point clouds: edge "flying pixels" and small
// isolated patches.
//
// Two grid neighbours are *connected* when their 3D distance is at most
// max_slope_factor * (pixel footprint) * (grid distance), the footprint being depth / focal
// length (the size of a pixel on a fronto-parallel surface at that depth); a factor of 5 accepts
// surfaces up to ~78 deg from fronto-parallel. A point with fewer than min_neighbours connected
// 8-neighbours is a flying pixel (mixed or wrongly matched pixels at depth edges) and removed;
// then connected components (8-connectivity over connected pairs) smaller than
// min_component_px are removed (isolated wrong matches).
//
// Frames: the cloud's camera frame (the camera at the origin looking along +z), mm.
// Thread safety: parallel (TBB) inside; results do not depend on the number of threads.
#pragma once

#include <string>

#include "fringe/geometry/point_cloud.h"

namespace fringe::stereo {

struct OutlierOptions {
  // Allowed neighbour distance in pixel footprints per grid step, > 0.
  double max_slope_factor = 5.0;
  // Connected 8-neighbours a point needs to stay, [0, 8].
  int min_neighbours = 2;
  // Smallest kept component, pixels, >= 1.
  int min_component_px = 50;
  void Check() const;
};

enum class OutlierStatus {
  kOk = 0,
  kNoPoints,    // the cloud had no valid point to begin with
  kAllRemoved,  // every point was removed
};
const char* ToString(OutlierStatus status);

struct OutlierSummary {
  OutlierStatus status = OutlierStatus::kOk;
  std::string message;       // why, when status is not kOk
  int flying_pixels = 0;     // removed for too few connected neighbours
  int small_components = 0;  // removed components
  int component_points = 0;  // points removed with them
  int kept = 0;
  bool ok() const { return status == OutlierStatus::kOk; }
  std::string BriefReport() const;
};

// Marks the outliers invalid (valid = 0, position NaN). `focal_px` is the focal length of the
// camera whose grid the cloud is on (pixels, > 0): a point's footprint, the distance one grid
// step spans at its depth, is depth / focal_px. Throws fringe::Error for bad options.
OutlierSummary RemoveOrganizedOutliers(OrganizedPointCloud* grid, double focal_px,
                                       const OutlierOptions& options = {});

}  // namespace fringe::stereo
