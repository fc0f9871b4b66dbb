#include "fringe/sim/ray_caster.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "fringe/util/error.h"

namespace fringe::sim {

struct RayCaster::Impl {
  Scene scene;
  RTCDevice device = nullptr;
  RTCScene rtc = nullptr;
  // Marker lookup grid (empty: no markers).
  Eigen::Vector3d grid_min = Eigen::Vector3d::Zero();
  double cell_mm = 1;
  int grid_size[3] = {0, 0, 0};
  std::vector<std::vector<int>> cells;

  ~Impl() {
    if (rtc) rtcReleaseScene(rtc);
    if (device) rtcReleaseDevice(device);
  }

  void Build() {
    device = rtcNewDevice(nullptr);
    if (!device) throw Error("Embree: cannot create a device");
    rtc = rtcNewScene(device);
    rtcSetSceneFlags(rtc, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(rtc, RTC_BUILD_QUALITY_HIGH);
    for (size_t i = 0; i < scene.objects().size(); ++i) {
      const TriangleMesh& mesh = scene.objects()[i].mesh;
      RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
      auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                            RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                            mesh.vertices.size()));
      for (size_t k = 0; k < mesh.vertices.size(); ++k) {
        for (int d = 0; d < 3; ++d) v[3 * k + d] = static_cast<float>(mesh.vertices[k][d]);
      }
      auto* t = static_cast<uint32_t*>(
          rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                  3 * sizeof(uint32_t), mesh.triangles.size()));
      for (size_t k = 0; k < mesh.triangles.size(); ++k) {
        for (int d = 0; d < 3; ++d) t[3 * k + d] = static_cast<uint32_t>(mesh.triangles[k][d]);
      }
      rtcCommitGeometry(geom);
      rtcAttachGeometryByID(rtc, geom, static_cast<unsigned>(i));
      rtcReleaseGeometry(geom);
    }
    rtcCommitScene(rtc);
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) {
      throw Error("Embree: building the scene failed");
    }
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

  static void FillRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                      double t_max, RTCRay* ray) {
    ray->org_x = static_cast<float>(o.x());
    ray->org_y = static_cast<float>(o.y());
    ray->org_z = static_cast<float>(o.z());
    ray->dir_x = static_cast<float>(d.x());
    ray->dir_y = static_cast<float>(d.y());
    ray->dir_z = static_cast<float>(d.z());
    ray->tnear = static_cast<float>(t_min);
    ray->tfar = static_cast<float>(t_max);
    ray->mask = 0xFFFFFFFFu;
    ray->flags = 0;
    ray->time = 0;
    ray->id = 0;
  }

  static void FillRayHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                         RTCRayHit* rh) {
    FillRay(o, d, t_min, std::numeric_limits<float>::infinity(), &rh->ray);
    rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  }

  // Embree's float hit refined in double precision on the hit triangle's plane or the exact
  // sphere.
  std::optional<Hit> Refine(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                            const RTCRayHit& rh) const {
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    Hit hit;
    hit.object = static_cast<int>(rh.hit.geomID);
    hit.triangle = static_cast<int>(rh.hit.primID);
    const SceneObject& obj = scene.objects()[hit.object];
    double t = rh.ray.tfar;
    if (obj.sphere) {
      // Exact sphere: the root nearest Embree's hit on the inscribed tessellation.
      const Eigen::Vector3d oc = o - obj.sphere->centre;
      const double b = d.dot(oc);
      const double c = oc.squaredNorm() - obj.sphere->radius_mm * obj.sphere->radius_mm;
      const double disc = b * b - c;
      if (disc >= 0) {
        const double s = std::sqrt(disc);
        const double t1 = -b - s, t2 = -b + s;
        t = (std::abs(t1 - t) <= std::abs(t2 - t)) ? t1 : t2;
      } else {
        t = -b;
      }
      hit.t = t;
      hit.point = o + t * d;
      hit.normal = (hit.point - obj.sphere->centre).normalized();
    } else {
      const auto& tri = obj.mesh.triangles[hit.triangle];
      const Eigen::Vector3d& v0 = obj.mesh.vertices[tri[0]];
      const Eigen::Vector3d n =
          (obj.mesh.vertices[tri[1]] - v0).cross(obj.mesh.vertices[tri[2]] - v0);
      const double nn = n.norm();
      const double den = d.dot(n);
      if (nn > 0 && std::abs(den) > 1e-12 * nn) t = (v0 - o).dot(n) / den;
      hit.t = t;
      hit.point = o + t * d;
      hit.normal = nn > 0 ? Eigen::Vector3d(n / nn)
                          : Eigen::Vector3d(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z).normalized();
    }
    return hit;
  }

  std::optional<Hit> Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh;
    FillRayHit(o, d, t_min, &rh);
    rtcIntersect1(rtc, &ctx, &rh);
    return Refine(o, d, rh);
  }

  // True when something lies between `from` and `to`.
  bool Occluded(const Eigen::Vector3d& from, const Eigen::Vector3d& to) const {
    const Eigen::Vector3d delta = to - from;
    const double dist = delta.norm();
    const Eigen::Vector3d d = delta / dist;
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay ray;
    ray.org_x = static_cast<float>(from.x());
    ray.org_y = static_cast<float>(from.y());
    ray.org_z = static_cast<float>(from.z());
    ray.dir_x = static_cast<float>(d.x());
    ray.dir_y = static_cast<float>(d.y());
    ray.dir_z = static_cast<float>(d.z());
    ray.tnear = 0.0f;
    ray.tfar = static_cast<float>(dist);
    ray.mask = 0xFFFFFFFFu;
    ray.flags = 0;
    ray.time = 0;
    ray.id = 0;
    rtcOccluded1(rtc, &ctx, &ray);
    return ray.tfar < 0;
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

RayCaster::RayCaster(const Scene& scene) : impl_(std::make_unique<Impl>()) {
  if (scene.objects().empty()) throw Error("RayCaster: the scene has no objects");
  // Marker ids index the scene's marker list.
  for (size_t i = 0; i < scene.markers().size(); ++i) {
    if (scene.markers()[i].id != static_cast<int>(i)) {
      throw Error(util::StrCat("RayCaster: marker ", i, " has id ", scene.markers()[i].id,
                               " (ids must be 0, 1, 2, ... in order)"));
    }
  }
  impl_->scene = scene;
  impl_->Build();
}

RayCaster::~RayCaster() = default;

const Scene& RayCaster::scene() const { return impl_->scene; }

std::optional<Hit> RayCaster::Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                   double t_min) const {
  return impl_->Cast(origin, dir, t_min);
}

bool RayCaster::Occluded(const Eigen::Vector3d& from, const Eigen::Vector3d& to) const {
  return impl_->Occluded(from, to);
}

double RayCaster::Albedo(const Hit& hit) const { return impl_->Albedo(hit); }

void RayCaster::CastBatch(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3d>& dirs,
                          std::vector<std::optional<Hit>>* hits) const {
  thread_local std::vector<RTCRayHit> rays;
  rays.resize(dirs.size());
  for (size_t i = 0; i < dirs.size(); ++i) Impl::FillRayHit(origin, dirs[i], 0.0, &rays[i]);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  if (!rays.empty()) {
    rtcIntersect1M(impl_->rtc, &ctx, rays.data(), static_cast<unsigned>(rays.size()),
                   sizeof(RTCRayHit));
  }
  hits->resize(dirs.size());
  for (size_t i = 0; i < dirs.size(); ++i) (*hits)[i] = impl_->Refine(origin, dirs[i], rays[i]);
}

void RayCaster::OccludedBatch(const std::vector<Eigen::Vector3d>& from, const Eigen::Vector3d& to,
                              std::vector<uint8_t>* occluded) const {
  thread_local std::vector<RTCRay> rays;
  rays.resize(from.size());
  for (size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector3d delta = to - from[i];
    const double dist = delta.norm();
    Impl::FillRay(from[i], delta / dist, 0.0, dist, &rays[i]);
  }
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  if (!rays.empty()) {
    rtcOccluded1M(impl_->rtc, &ctx, rays.data(), static_cast<unsigned>(rays.size()),
                  sizeof(RTCRay));
  }
  occluded->resize(from.size());
  for (size_t i = 0; i < from.size(); ++i) (*occluded)[i] = rays[i].tfar < 0 ? 1 : 0;
}

}  // namespace fringe::sim
