// Fusion in spatial tiles, for scans whose views do not fit in memory together.
//
// The registered bounding box of all views is cut into cubic tiles of tile_size_mm. Each tile
// is fused on its own (FuseViews) from the parts of the views that reach its core plus a margin
// on every side, and keeps the fused points whose position falls in its core: every fused point
// belongs to exactly one tile (half-open cores; a point outside the grid, e.g. a centre moved
// past the outermost box, counts in the nearest tile). Fusion is local: a fused point depends on
// the points within its cluster radius (spacing_factor spacings plus the registration term),
// its seed radius and the border distances of its views' grids (up to border_* / *_border_px
// pixels); a margin of margin_spacings spacings plus the registration term covers these and the
// chains between neighbouring clusters, so a core point is fused from the same neighbourhood as
// in the whole at once. What remains tile-dependent are the statistics fusion takes over a whole
// call (each view's median spacing, which bounds isolated and grazing points' spacing, the
// median cluster disagreement, the median spacing of the travel limit): computed over the tile's
// points they differ slightly from the whole scan's, so the tiled result equals the whole-at-once
// result within a tolerance (fusion/tiles_test.cc states it: equal point counts within 0.5 %,
// 99 % of the points within 1 um of a whole-at-once point), not bit for bit.
//
// Out of core: a view is loaded once (TiledView::load, e.g. from its PLY on disk), cut into the
// pieces each tile needs (a rectangle of its grid: the bounding rectangle of the slots whose
// point lies in the tile's core plus margin; the rectangle's edge is a frame edge, no border),
// and the pieces are written to a scratch folder; then the tiles are fused one after the other,
// each from its pieces read back, so that memory holds one full view while cutting and one
// tile's pieces (plus the growing output) while fusing. Fusion runs in parallel inside a tile
// (TBB), one tile at a time.
//
// Frames and units: views in their sensor frames, placed by world_from_sensor; tiles and the
// output in the world frame; millimetres.
// Thread safety: FuseTiled may run concurrently with other calls given distinct scratch folders;
// `load` is called from the calling thread only.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "fringe/fusion/fuse.h"

namespace fringe::fusion {

struct TileOptions {
  // Edge of a tile's core, mm, > 0; infinity (the default): one tile, the whole at once.
  double tile_size_mm = std::numeric_limits<double>::infinity();
  // Margin around a core, mm, >= 0; 0: margin_spacings * the largest view spacing (TiledView::
  // spacing_mm) + 2 * the registration term of the fusion radius.
  double margin_mm = 0;
  // See margin_mm: 24 covers the cluster radius (3 spacings), the seed radius at borders (3),
  // the border effects (up to 6 px) and the chains between clusters with room to spare, (0, 1000].
  double margin_spacings = 24;
  // Where the views' pieces go between cutting and fusing (created, emptied at the end); must be
  // given when there is more than one tile.
  std::filesystem::path scratch_dir;

  void Check() const;
};

// What FuseTiled needs of a view without holding it: its placement, its grid's size, the world
// box of its valid points, its point spacing, and how to load it.
struct TiledView {
  std::string name;
  Rigid3d world_from_sensor;
  int width = 0, height = 0;
  Eigen::AlignedBox3d box_in_world;           // of its valid points, placed
  double spacing_mm = 0;                      // median distance between grid neighbours, > 0
  std::function<OrganizedPointCloud()> load;  // the grid (sensor frame); may throw
};

// Box and spacing of `grid` placed by world_from_sensor (spacing: GridSpacingMm).
TiledView DescribeTiledView(const std::string& name, const OrganizedPointCloud& grid,
                            const Rigid3d& world_from_sensor,
                            std::function<OrganizedPointCloud()> load);
// The same for a grid no longer held (the scanner drops the grids before registration when it
// will fuse in tiles): its size and GridSpacingMm, and its valid points (any order; e.g.
// grid.Compact()), which give the same box.
TiledView DescribeTiledView(const std::string& name, int width, int height, double spacing_mm,
                            const PointCloud& valid_points, const Rigid3d& world_from_sensor,
                            std::function<OrganizedPointCloud()> load);
// Median distance between horizontally adjacent valid slots, over a sample of rows; 0 without
// such a pair.
double GridSpacingMm(const OrganizedPointCloud& grid);

// The margin FuseTiled uses (TileOptions::margin_mm, or the automatic one), mm.
double TileMarginMm(const std::vector<TiledView>& views, const FusionOptions& options,
                    const TileOptions& tile_options);

struct TiledFusionSummary {
  int tiles = 0;        // tiles whose core plus margin reaches a view
  int tiles_fused = 0;  // of those, tiles with points in their pieces
  double tile_size_mm = 0, margin_mm = 0;
  int64_t max_tile_points = 0;   // largest number of input points of one tile (pieces)
  int64_t piece_points = 0;      // input points over all tiles (>= the views' points: margins)
  double cut_s = 0, fuse_s = 0;  // wall time of cutting the views, of fusing the tiles
};
nlohmann::json ToJson(const TiledFusionSummary& s);

struct TiledFusionResult {
  // As FusionResult: fused (world frame), support and view per fused point, overlap per view
  // and grid slot (full grid size); the order is tile by tile. summary adds the tiles' counts
  // (points in their cores) and times; its medians and iterations are the largest of the tiles'.
  FusionResult result;
  TiledFusionSummary tiles;
};

// Fuses the views tile by tile. Bad options throw fringe::Error; bad data come back as the
// fusion status of the first tile that failed (with the tile named in the message).
TiledFusionResult FuseTiled(const std::vector<TiledView>& views, const FusionOptions& options,
                            const TileOptions& tile_options);

}  // namespace fringe::fusion
