#include "fringe/fusion/tiles.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "fringe/io/ply.h"
#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::fusion {
namespace fs = std::filesystem;
using util::StrCat;

namespace {

// More tiles than this is a tile size far below any useful one (each tile costs a FuseViews call
// and files): refused rather than run for hours.
constexpr int64_t kMaxTiles = 1'000'000;

// The tile grid over the world box: cubic cells of `size` from `origin`, n cells per axis.
struct TileGrid {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double size = 0;
  Eigen::Array3i n = Eigen::Array3i::Ones();

  int64_t count() const { return int64_t{n[0]} * n[1] * n[2]; }
  // The cell index along axis a of coordinate x, clamped into the grid.
  int Cell(double x, int a) const {
    if (n[a] == 1) return 0;
    const double c = std::floor((x - origin[a]) / size);
    return static_cast<int>(std::clamp(c, 0.0, double(n[a] - 1)));
  }
  int64_t Index(const Eigen::Array3i& c) const {
    return (int64_t{c[2]} * n[1] + c[1]) * n[0] + c[0];
  }
  int64_t TileOf(const Eigen::Vector3d& p) const {
    return Index(Eigen::Array3i(Cell(p.x(), 0), Cell(p.y(), 1), Cell(p.z(), 2)));
  }
};

// Slot rectangle of one view's piece of one tile (inclusive bounds).
struct Rect {
  int c0 = std::numeric_limits<int>::max(), r0 = std::numeric_limits<int>::max();
  int c1 = -1, r1 = -1;
  void Extend(int c, int r) {
    c0 = std::min(c0, c), r0 = std::min(r0, r), c1 = std::max(c1, c), r1 = std::max(r1, r);
  }
  int width() const { return c1 - c0 + 1; }
  int height() const { return r1 - r0 + 1; }
};

template <typename T>
void CopyRows(const std::vector<T>& from, int from_width, const Rect& rect, std::vector<T>* to) {
  if (from.empty()) return;
  to->resize(static_cast<size_t>(rect.width()) * rect.height());
  for (int r = 0; r < rect.height(); ++r) {
    const auto begin = from.begin() + static_cast<ptrdiff_t>(r + rect.r0) * from_width + rect.c0;
    std::copy(begin, begin + rect.width(), to->begin() + static_cast<ptrdiff_t>(r) * rect.width());
  }
}

OrganizedPointCloud Crop(const OrganizedPointCloud& g, const Rect& rect) {
  OrganizedPointCloud out;
  out.width = rect.width();
  out.height = rect.height();
  CopyRows(g.valid, g.width, rect, &out.valid);
  CopyRows(g.cloud.points, g.width, rect, &out.cloud.points);
  CopyRows(g.cloud.normals, g.width, rect, &out.cloud.normals);
  CopyRows(g.cloud.colors, g.width, rect, &out.cloud.colors);
  CopyRows(g.cloud.intensity, g.width, rect, &out.cloud.intensity);
  CopyRows(g.cloud.quality, g.width, rect, &out.cloud.quality);
  CopyRows(g.cloud.residual_px, g.width, rect, &out.cloud.residual_px);
  return out;
}

OrganizedPointCloud LoadChecked(const TiledView& v) {
  OrganizedPointCloud g = v.load();
  g.CheckConsistent();
  if (g.width != v.width || g.height != v.height) {
    throw Error(StrCat("fusion tiles: view '", v.name, "' loaded as a ", g.width, " x ", g.height,
                       " grid, described as ", v.width, " x ", v.height));
  }
  return g;
}

// The fusion radius' registration term (FusionOptions).
double RegistrationTermMm(const FusionOptions& o) {
  return o.registration_factor * o.registration_rms_mm;
}

// Adds a tile's FuseViews summary into the total (counts that the caller recounts over the
// cores are left to it).
void Accumulate(const FusionSummary& t, FusionSummary* s) {
  s->unassigned += t.unassigned;
  s->absorbed += t.absorbed;
  s->trimmed += t.trimmed;
  s->absorbed_clusters += t.absorbed_clusters;
  s->disagreeing_clusters += t.disagreeing_clusters;
  s->iterations = std::max(s->iterations, t.iterations);
  s->moving_centres += t.moving_centres;
  s->last_max_shift_mm = std::max(s->last_max_shift_mm, t.last_max_shift_mm);
  s->median_spacing_mm = std::max(s->median_spacing_mm, t.median_spacing_mm);
  s->single_coverage_noise_mm = std::max(s->single_coverage_noise_mm, t.single_coverage_noise_mm);
  s->max_fit_error_px = std::max(s->max_fit_error_px, t.max_fit_error_px);
  s->prepare_s += t.prepare_s;
  s->overlap_s += t.overlap_s;
  s->candidates_s += t.candidates_s;
  s->cluster_s += t.cluster_s;
  s->output_s += t.output_s;
}

}  // namespace

void TileOptions::Check() const {
  constexpr const char* kName = "TileOptions";
  util::CheckOption(tile_size_mm > 0 && !std::isnan(tile_size_mm), kName, "tile_size_mm",
                    tile_size_mm, "must be > 0 (infinity: one tile)");
  util::CheckOption(margin_mm >= 0 && std::isfinite(margin_mm), kName, "margin_mm", margin_mm,
                    "must be finite and >= 0");
  util::CheckOption(margin_spacings > 0 && margin_spacings <= 1000, kName, "margin_spacings",
                    margin_spacings, "must be in (0, 1000]");
}

TiledView DescribeTiledView(const std::string& name, const OrganizedPointCloud& grid,
                            const Rigid3d& world_from_sensor,
                            std::function<OrganizedPointCloud()> load) {
  grid.CheckConsistent();
  TiledView v;
  v.name = name;
  v.world_from_sensor = world_from_sensor;
  v.width = grid.width;
  v.height = grid.height;
  v.load = std::move(load);
  for (size_t i = 0; i < grid.valid.size(); ++i) {
    if (grid.valid[i]) v.box_in_world.extend(world_from_sensor * grid.cloud.points[i]);
  }
  v.spacing_mm = GridSpacingMm(grid);
  return v;
}

TiledView DescribeTiledView(const std::string& name, int width, int height, double spacing_mm,
                            const PointCloud& valid_points, const Rigid3d& world_from_sensor,
                            std::function<OrganizedPointCloud()> load) {
  TiledView v;
  v.name = name;
  v.world_from_sensor = world_from_sensor;
  v.width = width;
  v.height = height;
  v.load = std::move(load);
  for (const Eigen::Vector3d& p : valid_points.points) v.box_in_world.extend(world_from_sensor * p);
  v.spacing_mm = spacing_mm;
  return v;
}

double GridSpacingMm(const OrganizedPointCloud& grid) {
  // Every 8th row is plenty for a median (a grid has hundreds of rows).
  std::vector<double> d;
  for (int r = 0; r < grid.height; r += 8) {
    for (int c = 0; c + 1 < grid.width; ++c) {
      const size_t i = grid.index(c, r);
      if (grid.valid[i] && grid.valid[i + 1])
        d.push_back((grid.cloud.points[i + 1] - grid.cloud.points[i]).norm());
    }
  }
  if (d.empty()) return 0;
  std::nth_element(d.begin(), d.begin() + static_cast<ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

double TileMarginMm(const std::vector<TiledView>& views, const FusionOptions& options,
                    const TileOptions& tile_options) {
  if (tile_options.margin_mm > 0) return tile_options.margin_mm;
  double spacing_mm = 0;
  for (const TiledView& v : views) spacing_mm = std::max(spacing_mm, v.spacing_mm);
  return tile_options.margin_spacings * spacing_mm + 2 * RegistrationTermMm(options);
}

nlohmann::json ToJson(const TiledFusionSummary& s) {
  return {{"tiles", s.tiles},
          {"tiles_fused", s.tiles_fused},
          {"tile_size_mm", std::isfinite(s.tile_size_mm) ? nlohmann::json(s.tile_size_mm)
                                                         : nlohmann::json(nullptr)},
          {"margin_mm", s.margin_mm},
          {"max_tile_points", s.max_tile_points},
          {"piece_points", s.piece_points},
          {"cut_s", s.cut_s},
          {"fuse_s", s.fuse_s}};
}

TiledFusionResult FuseTiled(const std::vector<TiledView>& views, const FusionOptions& options,
                            const TileOptions& tile_options) {
  options.Check();
  tile_options.Check();
  TiledFusionResult out;
  TiledFusionSummary& ts = out.tiles;
  FusionResult& total = out.result;
  util::Timer timer;

  // The grid over the views' boxes.
  Eigen::AlignedBox3d box;
  for (const TiledView& v : views) {
    if (!v.box_in_world.isEmpty()) box.extend(v.box_in_world);
  }
  ts.margin_mm = TileMarginMm(views, options, tile_options);
  TileGrid grid;
  grid.size = tile_options.tile_size_mm;
  ts.tile_size_mm = grid.size;
  if (!box.isEmpty()) {
    grid.origin = box.min();
    if (std::isfinite(grid.size)) {
      for (int a = 0; a < 3; ++a) {
        const double cells = std::max(1.0, std::ceil(box.sizes()[a] / grid.size));
        if (cells > double(kMaxTiles))
          grid.n[a] = static_cast<int>(kMaxTiles) + 1;
        else
          grid.n[a] = static_cast<int>(cells);
      }
      if (double(grid.n[0]) * grid.n[1] * grid.n[2] > double(kMaxTiles)) {
        throw Error(StrCat("fusion tiles: tile_size_mm ", grid.size, " cuts the views' ",
                           box.sizes().x(), " x ", box.sizes().y(), " x ", box.sizes().z(),
                           " mm box into more than ", kMaxTiles, " tiles"));
      }
    }
  }

  // One tile: the whole at once, the views as they are.
  if (grid.count() == 1 || views.empty()) {
    std::vector<FusionView> whole;
    for (const TiledView& v : views) whole.push_back({v.name, LoadChecked(v), v.world_from_sensor});
    ts.cut_s = timer.ElapsedSeconds();
    timer.Restart();
    total = FuseViews(whole, options);
    ts.tiles = ts.tiles_fused = views.empty() ? 0 : 1;
    for (const FusionView& v : whole) ts.piece_points += static_cast<int64_t>(v.cloud.NumValid());
    ts.max_tile_points = ts.piece_points;
    ts.fuse_s = timer.ElapsedSeconds();
    return out;
  }
  if (tile_options.scratch_dir.empty())
    throw Error("fusion tiles: TileOptions::scratch_dir must be given for more than one tile");

  // Cutting: each view once, its pieces to the scratch folder.
  fs::create_directories(tile_options.scratch_dir);
  struct Piece {
    int view = 0;
    Rect rect;
    int64_t points = 0;
    fs::path file;
  };
  std::unordered_map<int64_t, std::vector<Piece>> pieces;  // by tile
  FusionSummary& s = total.summary;
  s.views = static_cast<int>(views.size());
  total.overlap.resize(views.size());
  const double margin = ts.margin_mm;
  for (size_t v = 0; v < views.size(); ++v) {
    const TiledView& tv = views[v];
    total.overlap[v].assign(static_cast<size_t>(tv.width) * tv.height, 0);
    if (tv.box_in_world.isEmpty()) continue;
    const OrganizedPointCloud g = LoadChecked(tv);
    std::unordered_map<int64_t, Piece> of_view;
    for (int r = 0; r < g.height; ++r) {
      for (int c = 0; c < g.width; ++c) {
        const size_t i = g.index(c, r);
        if (!g.valid[i]) continue;
        ++s.input_points;
        const Eigen::Vector3d p = tv.world_from_sensor * g.cloud.points[i];
        Eigen::Array3i lo, hi;
        for (int a = 0; a < 3; ++a) {
          lo[a] = grid.Cell(p[a] - margin, a);
          hi[a] = grid.Cell(p[a] + margin, a);
        }
        for (int z = lo[2]; z <= hi[2]; ++z) {
          for (int y = lo[1]; y <= hi[1]; ++y) {
            for (int x = lo[0]; x <= hi[0]; ++x) {
              Piece& piece = of_view[grid.Index({x, y, z})];
              piece.rect.Extend(c, r);
            }
          }
        }
      }
    }
    for (auto& [tile, piece] : of_view) {
      piece.view = static_cast<int>(v);
      piece.file = tile_options.scratch_dir / StrCat("tile", tile, "_view", v, ".ply");
      const OrganizedPointCloud cut = Crop(g, piece.rect);
      piece.points = static_cast<int64_t>(cut.NumValid());
      io::WritePly(piece.file, cut);
      pieces[tile].push_back(std::move(piece));
    }
  }
  ts.cut_s = timer.ElapsedSeconds();
  timer.Restart();

  // Fusing: tile by tile in index order (deterministic), each from its pieces.
  std::vector<int64_t> order;
  for (const auto& [tile, list] : pieces) order.push_back(tile);
  std::sort(order.begin(), order.end());
  ts.tiles = static_cast<int>(order.size());
  PointCloud& fused = total.fused;
  bool any_overlap = false, any_output = false;
  for (int64_t tile : order) {
    std::vector<Piece>& list = pieces[tile];
    std::sort(list.begin(), list.end(),
              [](const Piece& a, const Piece& b) { return a.view < b.view; });
    std::vector<FusionView> in;
    int64_t points = 0;
    for (const Piece& p : list) {
      in.push_back({views[static_cast<size_t>(p.view)].name, io::ReadOrganizedPly(p.file),
                    views[static_cast<size_t>(p.view)].world_from_sensor});
      fs::remove(p.file);
      points += p.points;
    }
    ts.piece_points += points;
    ts.max_tile_points = std::max(ts.max_tile_points, points);
    const FusionResult r = FuseViews(in, options);
    const FusionSummary& rs = r.summary;
    if (rs.status == FusionStatus::kEmptyInput) continue;
    if (!rs.has_output()) {
      s.status = rs.status;
      s.message = StrCat("tile ", tile, ": ", rs.message);
      fs::remove_all(tile_options.scratch_dir);
      return out;
    }
    ++ts.tiles_fused;
    any_output = true;
    any_overlap |= rs.status == FusionStatus::kOk;
    Accumulate(rs, &s);
    // The fused points in the core (every tile's output has the same attributes).
    for (size_t i = 0; i < r.fused.size(); ++i) {
      if (grid.TileOf(r.fused.points[i]) != tile) continue;
      fused.PushBackFrom(r.fused, i);
      total.support.push_back(r.support[i]);
      total.view.push_back(static_cast<uint16_t>(list[r.view[i]].view));
      if (static_cast<int64_t>(i) < rs.clusters) {
        ++s.clusters;
      } else {
        ++s.passed_through;
      }
    }
    // The overlap flags of the slots whose point lies in the core.
    for (size_t k = 0; k < list.size() && k < r.overlap.size(); ++k) {
      const Piece& p = list[k];
      const TiledView& tv = views[static_cast<size_t>(p.view)];
      const OrganizedPointCloud& piece = in[k].cloud;
      for (size_t j = 0; j < r.overlap[k].size(); ++j) {
        if (!r.overlap[k][j] || grid.TileOf(tv.world_from_sensor * piece.cloud.points[j]) != tile)
          continue;
        const int rr = static_cast<int>(j) / p.rect.width(),
                  cc = static_cast<int>(j) % p.rect.width();
        total.overlap[static_cast<size_t>(p.view)]
                     [static_cast<size_t>(rr + p.rect.r0) * tv.width + (cc + p.rect.c0)] = 1;
      }
    }
  }
  fs::remove_all(tile_options.scratch_dir);
  for (const std::vector<uint8_t>& o : total.overlap)
    s.overlap_points += std::count(o.begin(), o.end(), 1);
  s.fused_points = static_cast<int64_t>(fused.size());
  if (!any_output) {
    s.status = FusionStatus::kEmptyInput;
    s.message = "no valid point in any view";
  } else {
    s.status = any_overlap ? FusionStatus::kOk : FusionStatus::kNoOverlap;
    s.converged = s.moving_centres <= static_cast<int64_t>(options.max_moving_fraction *
                                                           static_cast<double>(s.clusters));
  }
  ts.fuse_s = timer.ElapsedSeconds();
  s.time_s = ts.cut_s + ts.fuse_s;
  return out;
}

}  // namespace fringe::fusion
