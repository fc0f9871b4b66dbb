// Normals of an organized point cloud from its image grid (thesis capability 4).
//
// For every valid point, the normal is the direction of least spread (PCA) of the valid grid
// neighbours in a square window around its pixel; the window sums are box sums of the points'
// coordinate products (as PCL's integral-image normal estimation: Holzer et al., "Adaptive
// neighborhood selection for real-time surface normal estimation from organized point cloud data
// using integral images", IROS 2012), here per band of rows with per-thread row buffers instead
// of image-sized integral images (column sums over the window's rows, then per point the sum of
// its window's columns: no image-sized buffer, and no sum over the whole image to lose
// precision); normals_test checks them against a direct PCA of each window. Depth-discontinuity
// aware: pixels next to a depth jump (or a hole, or the image border) are edge pixels; each
// point's window is shrunk to stay on its own side of the nearest one and symmetric about the
// point (chessboard distance transform), and edge pixels use an explicit
// 5x5 window that keeps only neighbours on the same surface.
// Normals are oriented toward the camera that measured the cloud (the frame's origin):
// n . p < 0.
//
// Frames and units: the cloud's own frame (a view's left camera frame), millimetres.
// Thread safety: parallel (TBB) inside; results do not depend on the number of threads.
#pragma once

#include <string>

#include "fringe/geometry/point_cloud.h"

namespace fringe {

struct GridNormalOptions {
  // Half size of the square window in pixels, [1, 20]; (2r+1)^2 neighbours at most. 3 (7x7 =
  // 49 neighbours) averages noise about as much as 30 nearest neighbours.
  int window_radius_px = 3;
  // Neighbouring pixels whose depths differ by more than this are on different surfaces, mm,
  // > 0; the threshold grows with depth by relative_depth_jump.
  double max_depth_jump_mm = 0.5;
  // Depth-proportional part of the jump threshold (fraction of the depth), >= 0.
  double relative_depth_jump = 0.002;
  // Points with fewer usable neighbours (including themselves) get no normal, [3, 1000].
  int min_points = 4;

  void Check() const;
};

enum class GridNormalStatus {
  kOk = 0,
  kNoPoints,   // the cloud has no valid point
  kNoNormals,  // no point had enough neighbours for a normal
};
const char* ToString(GridNormalStatus status);

struct GridNormalSummary {
  GridNormalStatus status = GridNormalStatus::kOk;
  std::string message;  // why, when status is not kOk
  int normals = 0;      // points that got a normal
  int missing = 0;      // valid points left without one (too few neighbours)
  int edge_points = 0;  // points next to a depth jump, a hole or the image border
  double time_s = 0;
  bool ok() const { return status == GridNormalStatus::kOk; }
  std::string BriefReport() const;
};

// Fills grid->cloud.normals (allocated when absent); points without a normal get NaN.
GridNormalSummary EstimateGridNormals(OrganizedPointCloud* grid,
                                      const GridNormalOptions& options = {});

}  // namespace fringe
