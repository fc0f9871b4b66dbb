// The scanner's memory budget: what the stages need,
// estimated from the data's sizes, against ScanOptions::memory_limit_gib.
//
// What grows with the number of views and what does not:
//   - views are reconstructed a few at a time (ScanOptions::views_in_flight), each needing its
//     image stacks and its working buffers (ViewWorkBytes); the limit lowers views_in_flight to
//     what fits and refuses a limit below one view;
//   - registration holds a compact copy of every view (its points, normals and a grid index);
//     that part grows with the views and is what the budget of the later stages starts from (it
//     is measured, the process' resident memory after registration);
//   - fusion either fuses every view at once (FusionBytes of all points) or, when that does not
//     fit beside the compact copies, fuses spatial tiles streamed from OUT/views/ (fusion/
//     tiles.h), the tile size chosen so that one tile's pieces fit (ChooseTileSize); which one is
//     decided before registration, so that a tiled scan drops the views' grids before it;
//   - meshing runs once on the fused cloud, whose size is that of the part's surface (at the
//     points' spacing), not of the number of views.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace fringe::pipeline {

// The default limit: this fraction of the machine's physical memory (leaving the rest to the
// system and other programs).
inline constexpr double kDefaultMemoryFraction = 0.5;

// FuseViews' working memory per input point: bench_fusion measures 1.15 GiB of growth for the
// 5.68 M points of the full-rig demo scan (~217 bytes); with the input grids' own 61 bytes per
// slot (points, normals, attributes) and rectangles about half empty, 340 bytes per point.
inline constexpr double kFusionBytesPerPoint = 340;
// A loaded organized view per grid slot (double points and normals, float attributes, mask),
// plus the PLY reader's buffer: 61 + 32 bytes.
inline constexpr double kGridBytesPerSlot = 93;

// The limit to use: `limit_gib` when > 0, else kDefaultMemoryFraction of the physical memory
// (8 GiB when it is unknown).
double ResolveMemoryLimitGiB(double limit_gib);

// Bytes one view needs while it is reconstructed: `images` images per camera of width x height
// at bit_depth (16-bit storage above 8 bits) for each camera, plus the decoding, matching and
// normal buffers (~115 bytes per pixel: util/memory.h's ~150 MB for a 1.3 Mpx view).
double ViewWorkBytes(int width, int height, int images_per_camera, int cameras, int bit_depth);

// The largest cubic tile edge (mm) for which no tile's core plus margin_mm holds more than
// max_points points, `samples` (world frame) each standing for `sample_weight` points. Tried from
// the samples' largest extent down, by factors of 0.8, to min_tile_mm; 0 when none fits;
// infinity when everything fits in one tile. The count of a tile is what FuseTiled cuts for it.
double ChooseTileSize(const std::vector<Eigen::Vector3d>& samples, double sample_weight,
                      double margin_mm, double max_points, double min_tile_mm,
                      double* max_tile_points = nullptr);

}  // namespace fringe::pipeline
