#include "fringe/sim/ray_caster.h"

#include <algorithm>
#include <cmath>

#include "fringe/util/error.h"

namespace fringe::sim {

namespace {

std::vector<TriangleMesh> ObjectMeshes(const Scene& scene) {
  std::vector<TriangleMesh> meshes;
  meshes.reserve(scene.objects().size());
  for (const SceneObject& o : scene.objects()) {
    TriangleMesh m;
    m.vertices = o.mesh.vertices;
    m.triangles = o.mesh.triangles;
    meshes.push_back(std::move(m));
  }
  return meshes;
}

}  // namespace

struct RayCaster::Impl {
  Scene scene;
  // The objects' tessellations, one mesh per object in scene order. kHigh: a view casts millions
  // of coherent rays, where spatial splits pay for their longer build.
  MeshIndex index;
  // Marker lookup grid (empty: no markers).
  Eigen::Vector3d grid_min = Eigen::Vector3d::Zero();
  double cell_mm = 1;
  int grid_size[3] = {0, 0, 0};
  std::vector<std::vector<int>> cells;

  explicit Impl(const Scene& s) : scene(s), index(ObjectMeshes(s), BvhQuality::kHigh) {
    IndexMarkers();
  }

  // Markers are looked up through a coarse uniform grid over the markers' bounds: a hit only
  // checks the few markers whose sticker overlaps its cell.
  void IndexMarkers() {
    const auto& markers = scene.markers();
    if (markers.empty()) return;
    double max_radius = 0;
    grid_min = markers[0].centre_in_world;
    Eigen::Vector3d grid_max = grid_min;
    for (const Marker& m : markers) {
      max_radius = std::max(max_radius, m.outer_radius_mm);
      grid_min = grid_min.cwiseMin(m.centre_in_world);
      grid_max = grid_max.cwiseMax(m.centre_in_world);
    }
    cell_mm = std::max(4.0 * max_radius, 1.0);
    grid_min -= Eigen::Vector3d::Constant(max_radius + cell_mm);
    grid_max += Eigen::Vector3d::Constant(max_radius + cell_mm);
    for (int d = 0; d < 3; ++d) {
      grid_size[d] =
          std::max(1, static_cast<int>(std::ceil((grid_max[d] - grid_min[d]) / cell_mm)));
    }
    cells.assign(static_cast<size_t>(grid_size[0]) * grid_size[1] * grid_size[2], {});
    for (const Marker& m : markers) {
      const Eigen::Vector3d lo = m.centre_in_world - Eigen::Vector3d::Constant(m.outer_radius_mm);
      const Eigen::Vector3d hi = m.centre_in_world + Eigen::Vector3d::Constant(m.outer_radius_mm);
      int a[3], b[3];
      for (int d = 0; d < 3; ++d) {
        a[d] = std::clamp(static_cast<int>(std::floor((lo[d] - grid_min[d]) / cell_mm)), 0,
                          grid_size[d] - 1);
        b[d] = std::clamp(static_cast<int>(std::floor((hi[d] - grid_min[d]) / cell_mm)), 0,
                          grid_size[d] - 1);
      }
      for (int z = a[2]; z <= b[2]; ++z) {
        for (int y = a[1]; y <= b[1]; ++y) {
          for (int x = a[0]; x <= b[0]; ++x) cells[CellIndex(x, y, z)].push_back(m.id);
        }
      }
    }
  }

  size_t CellIndex(int x, int y, int z) const {
    return (static_cast<size_t>(z) * grid_size[1] + y) * grid_size[0] + x;
  }

  // Markers whose sticker may cover p, or nullptr.
  const std::vector<int>* MarkersNear(const Eigen::Vector3d& p) const {
    if (cells.empty()) return nullptr;
    int idx[3];
    for (int d = 0; d < 3; ++d) {
      const double f = std::floor((p[d] - grid_min[d]) / cell_mm);
      if (f < 0 || f >= grid_size[d]) return nullptr;
      idx[d] = static_cast<int>(f);
    }
    const std::vector<int>& list = cells[CellIndex(idx[0], idx[1], idx[2])];
    return list.empty() ? nullptr : &list;
  }

  // The index's hit on the tessellation, moved onto the exact sphere of sphere objects (the
  // root nearest the hit on the inscribed tessellation).
  std::optional<Hit> OnSurface(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                               const std::optional<MeshHit>& mesh_hit) const {
    if (!mesh_hit) return std::nullopt;
    Hit hit;
    hit.object = mesh_hit->mesh;
    hit.triangle = mesh_hit->triangle;
    hit.t = mesh_hit->t;
    hit.point = mesh_hit->point;
    hit.normal = mesh_hit->normal;
    const SceneObject& obj = scene.objects()[hit.object];
    if (!obj.sphere) return hit;
    const Eigen::Vector3d oc = o - obj.sphere->centre;
    const double b = d.dot(oc);
    const double c = oc.squaredNorm() - obj.sphere->radius_mm * obj.sphere->radius_mm;
    const double disc = b * b - c;
    double t = -b;
    if (disc >= 0) {
      const double s = std::sqrt(disc);
      const double t1 = -b - s, t2 = -b + s;
      t = (std::abs(t1 - hit.t) <= std::abs(t2 - hit.t)) ? t1 : t2;
    }
    hit.t = t;
    hit.point = o + t * d;
    hit.normal = (hit.point - obj.sphere->centre).normalized();
    return hit;
  }

  double Albedo(const Hit& hit) const {
    const SceneObject& obj = scene.objects()[hit.object];
    if (const std::vector<int>* near = MarkersNear(hit.point)) {
      for (int id : *near) {
        const Marker& m = scene.markers()[id];
        if (std::abs(hit.normal.dot(m.normal_in_world)) < 0.5) continue;  // another face
        const Eigen::Vector3d rel = hit.point - m.centre_in_world;
        const double along = rel.dot(m.normal_in_world);
        if (std::abs(along) > m.outer_radius_mm) continue;
        const double radial = (rel - along * m.normal_in_world).norm();
        if (radial < m.inner_radius_mm) return scene.marker_white_albedo;
        if (radial < m.outer_radius_mm) return scene.marker_black_albedo;
      }
    }
    if (obj.texture) return std::clamp(obj.texture(hit.point), 0.0, 1.0);
    return obj.albedo;
  }
};

namespace {

const Scene& Checked(const Scene& scene) {
  if (scene.objects().empty()) throw Error("RayCaster: the scene has no objects");
  // Marker ids index the scene's marker list.
  for (size_t i = 0; i < scene.markers().size(); ++i) {
    if (scene.markers()[i].id != static_cast<int>(i)) {
      throw Error(util::StrCat("RayCaster: marker ", i, " has id ", scene.markers()[i].id,
                               " (ids must be 0, 1, 2, ... in order)"));
    }
  }
  return scene;
}

}  // namespace

RayCaster::RayCaster(const Scene& scene) : impl_(std::make_unique<Impl>(Checked(scene))) {}

RayCaster::~RayCaster() = default;

const Scene& RayCaster::scene() const { return impl_->scene; }

std::optional<Hit> RayCaster::Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                   double t_min) const {
  return impl_->OnSurface(origin, dir, impl_->index.Cast(origin, dir, t_min));
}

const MeshIndex& RayCaster::index() const { return impl_->index; }

double RayCaster::Albedo(const Hit& hit) const { return impl_->Albedo(hit); }

void RayCaster::CastBatch(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3d>& dirs,
                          std::vector<std::optional<Hit>>* hits) const {
  thread_local std::vector<std::optional<MeshHit>> mesh_hits;
  impl_->index.CastBatch(origin, dirs, &mesh_hits);
  hits->resize(dirs.size());
  for (size_t i = 0; i < dirs.size(); ++i) {
    (*hits)[i] = impl_->OnSurface(origin, dirs[i], mesh_hits[i]);
  }
}

}  // namespace fringe::sim
