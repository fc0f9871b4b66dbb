#include "fringe/geometry/mesh_index.h"

#include <embree3/rtcore.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "fringe/util/error.h"

namespace fringe {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The process' Embree device, created on first use and kept to the end: Embree devices are
// thread-safe, and each one starts its own thread pool.
RTCDevice SharedDevice() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice(nullptr);
    if (!d) throw Error("Embree: cannot create a device");
    return d;
  }();
  return device;
}

// One mesh and the pseudo-normals derived from it.
struct MeshData {
  TriangleMesh mesh;
  std::vector<Eigen::Vector3d> face_normals;
  std::vector<Eigen::Vector3d> vertex_normals;               // angle-weighted
  std::vector<std::array<Eigen::Vector3d, 3>> edge_normals;  // per triangle: ab, bc, ca

  void DerivePseudoNormals() {
    face_normals.resize(mesh.triangles.size());
    vertex_normals.assign(mesh.vertices.size(), Eigen::Vector3d::Zero());
    edge_normals.resize(mesh.triangles.size());
    std::unordered_map<uint64_t, Eigen::Vector3d> edge_sum;
    auto key = [](int32_t a, int32_t b) {
      return (static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint32_t>(std::max(a, b));
    };
    for (size_t i = 0; i < mesh.triangles.size(); ++i) {
      const auto& t = mesh.triangles[i];
      const Eigen::Vector3d& a = mesh.vertices[t[0]];
      const Eigen::Vector3d& b = mesh.vertices[t[1]];
      const Eigen::Vector3d& c = mesh.vertices[t[2]];
      Eigen::Vector3d n = (b - a).cross(c - a);
      n = n.norm() > 0 ? n.normalized() : Eigen::Vector3d::Zero();
      face_normals[i] = n;
      const Eigen::Vector3d* v[3] = {&a, &b, &c};
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d e1 = (*v[(k + 1) % 3] - *v[k]).normalized();
        const Eigen::Vector3d e2 = (*v[(k + 2) % 3] - *v[k]).normalized();
        const double angle = std::acos(std::clamp(e1.dot(e2), -1.0, 1.0));
        if (std::isfinite(angle)) vertex_normals[t[k]] += angle * n;
        // try_emplace with an explicit zero: operator[] would value-initialize an Eigen vector,
        // which leaves it uninitialized, and the sign at edges then depended on stale memory
        // (a cube-edge sign that flipped in 2 of 40 runs).
        edge_sum.try_emplace(key(t[k], t[(k + 1) % 3]), Eigen::Vector3d::Zero()).first->second += n;
      }
    }
    for (size_t i = 0; i < mesh.triangles.size(); ++i) {
      const auto& t = mesh.triangles[i];
      for (int k = 0; k < 3; ++k) edge_normals[i][k] = edge_sum.at(key(t[k], t[(k + 1) % 3]));
    }
  }
};

// Closest point to p on segment [a, b] (a when the segment has no length).
Eigen::Vector3d ClosestOnSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                 const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len_sq = ab.squaredNorm();
  if (!(len_sq > 0)) return a;
  return a + std::clamp(ab.dot(p - a) / len_sq, 0.0, 1.0) * ab;
}

// Closest point to p on a triangle of no area (two vertices equal, or all three on a line):
// the closest of its three edges. Ericson's regions divide by edge lengths and by the area, so
// on such a triangle they give 0/0.
Eigen::Vector3d ClosestOnDegenerateTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                            const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                            int* feature) {
  const Eigen::Vector3d q[3] = {ClosestOnSegment(p, a, b), ClosestOnSegment(p, b, c),
                                ClosestOnSegment(p, c, a)};
  int best = 0;
  for (int k = 1; k < 3; ++k) {
    if ((q[k] - p).squaredNorm() < (q[best] - p).squaredNorm()) best = k;
  }
  *feature = 4 + best;
  return q[best];
}

// Closest point to p on triangle (a, b, c) and the feature it lies on:
// 0 face, 1/2/3 vertex a/b/c, 4/5/6 edge ab/bc/ca (Ericson 5.1.5). Always finite for finite
// input, also on triangles of no area (which Poisson's iso-surface produces where it clamps a
// root to a cell corner).
Eigen::Vector3d ClosestOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                  const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                  int* feature) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  if (!(ab.cross(ac).squaredNorm() > 0)) return ClosestOnDegenerateTriangle(p, a, b, c, feature);
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return *feature = 1, a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return *feature = 2, b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return *feature = 4, a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return *feature = 3, c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return *feature = 6, a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    return *feature = 5, b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const double sum = va + vb + vc;
  // A sliver whose area rounds away in the barycentric sums: its edges are as close.
  if (!(sum > 0)) return ClosestOnDegenerateTriangle(p, a, b, c, feature);
  const double denom = 1.0 / sum;
  *feature = 0;
  return a + ab * (vb * denom) + ac * (vc * denom);
}

struct Query {
  const std::vector<MeshData>* meshes = nullptr;
  Eigen::Vector3d p;
  double best_sq = std::numeric_limits<double>::infinity();
  // Mesh and triangle of best_sq (the lowest pair among equally close ones).
  unsigned best_geom = 0;
  unsigned best_prim = 0;
  Eigen::Vector3d closest = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
};

bool QueryCallback(RTCPointQueryFunctionArguments* args) {
  auto* q = static_cast<Query*>(args->userPtr);
  const MeshData& m = (*q->meshes)[args->geomID];
  const auto& t = m.mesh.triangles[args->primID];
  int feature = 0;
  const Eigen::Vector3d c = ClosestOnTriangle(q->p, m.mesh.vertices[t[0]], m.mesh.vertices[t[1]],
                                              m.mesh.vertices[t[2]], &feature);
  const double d2 = (c - q->p).squaredNorm();
  // A non-finite distance must not be kept: NaN compares false with everything, so it would let
  // the next triangle visited win whatever its distance.
  if (!std::isfinite(d2)) return false;
  // Equally close triangles (a shared vertex or edge) may give different normals: the lowest
  // (mesh, triangle) wins, so that the choice does not depend on Embree's traversal order.
  if (d2 > q->best_sq) return false;
  if (d2 == q->best_sq && (args->geomID > q->best_geom ||
                           (args->geomID == q->best_geom && args->primID >= q->best_prim))) {
    return false;
  }
  q->best_sq = d2;
  q->best_geom = args->geomID;
  q->best_prim = args->primID;
  q->closest = c;
  if (feature == 0) {
    q->normal = m.face_normals[args->primID];
  } else if (feature <= 3) {
    q->normal = m.vertex_normals[t[feature - 1]];
  } else {
    q->normal = m.edge_normals[args->primID][feature - 4];
  }
  // Float BVH bounds: keep a hair of slack so that equally close triangles are still visited.
  args->query->radius = static_cast<float>(std::sqrt(d2) * (1 + 1e-6) + 1e-6);
  return true;
}

void FillRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min, double t_max,
             RTCRay* ray) {
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

void FillRayHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min, RTCRayHit* rh) {
  FillRay(o, d, t_min, std::numeric_limits<float>::infinity(), &rh->ray);
  rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

// The context of a ray stream whose rays are coherent (one origin, or one target).
RTCIntersectContext CoherentContext() {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  return ctx;
}

}  // namespace

struct MeshIndex::Impl {
  std::vector<MeshData> meshes;
  RTCScene scene = nullptr;

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
  }

  void Build(BvhQuality quality) {
    RTCDevice device = SharedDevice();
    scene = rtcNewScene(device);
    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(
        scene, quality == BvhQuality::kHigh ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM);
    for (size_t i = 0; i < meshes.size(); ++i) {
      const TriangleMesh& mesh = meshes[i].mesh;
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
      rtcAttachGeometryByID(scene, geom, static_cast<unsigned>(i));
      rtcReleaseGeometry(geom);
    }
    rtcCommitScene(scene);
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) {
      throw Error("Embree: building the BVH of a mesh failed");
    }
  }

  // Embree's float hit recomputed in double precision on the hit triangle's plane.
  std::optional<MeshHit> Refine(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                const RTCRayHit& rh) const {
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    MeshHit hit;
    hit.mesh = static_cast<int>(rh.hit.geomID);
    hit.triangle = static_cast<int>(rh.hit.primID);
    const TriangleMesh& mesh = meshes[hit.mesh].mesh;
    const auto& tri = mesh.triangles[hit.triangle];
    const Eigen::Vector3d& v0 = mesh.vertices[tri[0]];
    const Eigen::Vector3d n = (mesh.vertices[tri[1]] - v0).cross(mesh.vertices[tri[2]] - v0);
    const double nn = n.norm();
    const double den = d.dot(n);
    double t = rh.ray.tfar;
    if (nn > 0 && std::abs(den) > 1e-12 * nn) t = (v0 - o).dot(n) / den;
    hit.t = t;
    hit.point = o + t * d;
    hit.normal = nn > 0 ? Eigen::Vector3d(n / nn)
                        : Eigen::Vector3d(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z).normalized();
    return hit;
  }
};

MeshIndex::MeshIndex(TriangleMesh mesh, BvhQuality quality)
    : MeshIndex(
          [&] {
            std::vector<TriangleMesh> v;
            v.push_back(std::move(mesh));
            return v;
          }(),
          quality) {}

MeshIndex::MeshIndex(std::vector<TriangleMesh> meshes, BvhQuality quality)
    : impl_(std::make_unique<Impl>()) {
  size_t triangles = 0;
  impl_->meshes.resize(meshes.size());
  for (size_t i = 0; i < meshes.size(); ++i) {
    meshes[i].Check(util::StrCat("mesh index: mesh ", i));
    triangles += meshes[i].triangles.size();
    impl_->meshes[i].mesh = std::move(meshes[i]);
    // Only the surface is indexed: per-vertex attributes would double the memory of a scan's mesh.
    impl_->meshes[i].mesh.normals.clear();
    impl_->meshes[i].mesh.colors.clear();
    impl_->meshes[i].DerivePseudoNormals();
  }
  if (triangles == 0) throw Error("mesh index: the mesh has no triangles");
  impl_->Build(quality);
}

MeshIndex::~MeshIndex() = default;

int MeshIndex::mesh_count() const { return static_cast<int>(impl_->meshes.size()); }

const TriangleMesh& MeshIndex::mesh(int i) const { return impl_->meshes.at(i).mesh; }

double MeshIndex::SignedDistance(const Eigen::Vector3d& p, double max_distance,
                                 Eigen::Vector3d* closest) const {
  if (!p.allFinite()) return kNaN;
  Query q;
  q.meshes = &impl_->meshes;
  q.p = p;
  RTCPointQuery pq;
  pq.x = static_cast<float>(p.x());
  pq.y = static_cast<float>(p.y());
  pq.z = static_cast<float>(p.z());
  pq.time = 0;
  pq.radius = static_cast<float>(std::min(max_distance, 1e30));
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  rtcPointQuery(impl_->scene, &pq, &context, QueryCallback, &q);
  if (!std::isfinite(q.best_sq) || q.best_sq > max_distance * max_distance) return kNaN;
  if (closest) *closest = q.closest;
  const double d = std::sqrt(q.best_sq);
  return (p - q.closest).dot(q.normal) < 0 ? -d : d;
}

std::optional<MeshHit> MeshIndex::Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                       double t_min) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  FillRayHit(origin, dir, t_min, &rh);
  rtcIntersect1(impl_->scene, &ctx, &rh);
  return impl_->Refine(origin, dir, rh);
}

bool MeshIndex::Occluded(const Eigen::Vector3d& from, const Eigen::Vector3d& to) const {
  const Eigen::Vector3d delta = to - from;
  const double dist = delta.norm();
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay ray;
  FillRay(from, delta / dist, 0.0, dist, &ray);
  rtcOccluded1(impl_->scene, &ctx, &ray);
  return ray.tfar < 0;
}

void MeshIndex::CastBatch(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3d>& dirs,
                          std::vector<std::optional<MeshHit>>* hits) const {
  thread_local std::vector<RTCRayHit> rays;
  rays.resize(dirs.size());
  for (size_t i = 0; i < dirs.size(); ++i) FillRayHit(origin, dirs[i], 0.0, &rays[i]);
  RTCIntersectContext ctx = CoherentContext();
  if (!rays.empty()) {
    rtcIntersect1M(impl_->scene, &ctx, rays.data(), static_cast<unsigned>(rays.size()),
                   sizeof(RTCRayHit));
  }
  hits->resize(dirs.size());
  for (size_t i = 0; i < dirs.size(); ++i) (*hits)[i] = impl_->Refine(origin, dirs[i], rays[i]);
}

void MeshIndex::OccludedBatch(const std::vector<Eigen::Vector3d>& from, const Eigen::Vector3d& to,
                              std::vector<uint8_t>* occluded) const {
  thread_local std::vector<RTCRay> rays;
  rays.resize(from.size());
  for (size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector3d delta = to - from[i];
    const double dist = delta.norm();
    FillRay(from[i], delta / dist, 0.0, dist, &rays[i]);
  }
  RTCIntersectContext ctx = CoherentContext();
  if (!rays.empty()) {
    rtcOccluded1M(impl_->scene, &ctx, rays.data(), static_cast<unsigned>(rays.size()),
                  sizeof(RTCRay));
  }
  occluded->resize(from.size());
  for (size_t i = 0; i < from.size(); ++i) (*occluded)[i] = rays[i].tfar < 0 ? 1 : 0;
}

}  // namespace fringe
