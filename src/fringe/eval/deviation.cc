#include "fringe/eval/deviation.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <unordered_map>

#include "fringe/util/error.h"

namespace fringe::eval {

// The mesh and the pseudo-normals derived from it.
struct MeshData {
  TriangleMesh mesh;
  std::vector<Eigen::Vector3d> face_normals;
  std::vector<Eigen::Vector3d> vertex_normals;               // angle-weighted
  std::vector<std::array<Eigen::Vector3d, 3>> edge_normals;  // per triangle: ab, bc, ca
};

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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
  const MeshData* mesh = nullptr;
  Eigen::Vector3d p;
  double best_sq = std::numeric_limits<double>::infinity();
  unsigned best_prim = 0;  // triangle of best_sq (the lowest index among equally close ones)
  Eigen::Vector3d closest = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
};

}  // namespace

struct MeshDistance::Impl {
  MeshData data;
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
};

namespace {

bool QueryCallback(RTCPointQueryFunctionArguments* args) {
  auto* q = static_cast<Query*>(args->userPtr);
  const MeshData& m = *q->mesh;
  const auto& t = m.mesh.triangles[args->primID];
  int feature = 0;
  const Eigen::Vector3d c = ClosestOnTriangle(q->p, m.mesh.vertices[t[0]], m.mesh.vertices[t[1]],
                                              m.mesh.vertices[t[2]], &feature);
  const double d2 = (c - q->p).squaredNorm();
  // A non-finite distance must not be kept: NaN compares false with everything, so it would let
  // the next triangle visited win whatever its distance.
  if (!std::isfinite(d2)) return false;
  // Equally close triangles (a shared vertex or edge) may give different normals: the lowest
  // triangle index wins, so that the choice does not depend on Embree's traversal order.
  if (d2 > q->best_sq || (d2 == q->best_sq && args->primID >= q->best_prim)) return false;
  q->best_sq = d2;
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

}  // namespace

MeshDistance::MeshDistance(TriangleMesh mesh) : impl_(std::make_unique<Impl>()) {
  MeshData& m = impl_->data;
  m.mesh = std::move(mesh);
  if (m.mesh.triangles.empty()) throw Error("deviation: the reference mesh has no triangles");
  m.mesh.Check("deviation: the reference mesh");
  m.face_normals.resize(m.mesh.triangles.size());
  m.vertex_normals.assign(m.mesh.vertices.size(), Eigen::Vector3d::Zero());
  m.edge_normals.resize(m.mesh.triangles.size());
  std::unordered_map<uint64_t, Eigen::Vector3d> edge_sum;
  auto key = [](int32_t a, int32_t b) {
    return (static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint32_t>(std::max(a, b));
  };
  for (size_t i = 0; i < m.mesh.triangles.size(); ++i) {
    const auto& t = m.mesh.triangles[i];
    const Eigen::Vector3d& a = m.mesh.vertices[t[0]];
    const Eigen::Vector3d& b = m.mesh.vertices[t[1]];
    const Eigen::Vector3d& c = m.mesh.vertices[t[2]];
    Eigen::Vector3d n = (b - a).cross(c - a);
    n = n.norm() > 0 ? n.normalized() : Eigen::Vector3d::Zero();
    m.face_normals[i] = n;
    const Eigen::Vector3d* v[3] = {&a, &b, &c};
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d e1 = (*v[(k + 1) % 3] - *v[k]).normalized();
      const Eigen::Vector3d e2 = (*v[(k + 2) % 3] - *v[k]).normalized();
      const double angle = std::acos(std::clamp(e1.dot(e2), -1.0, 1.0));
      if (std::isfinite(angle)) m.vertex_normals[t[k]] += angle * n;
      edge_sum[key(t[k], t[(k + 1) % 3])] += n;
    }
  }
  for (size_t i = 0; i < m.mesh.triangles.size(); ++i) {
    const auto& t = m.mesh.triangles[i];
    for (int k = 0; k < 3; ++k) m.edge_normals[i][k] = edge_sum[key(t[k], t[(k + 1) % 3])];
  }

  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device) throw Error("deviation: could not create an Embree device");
  impl_->scene = rtcNewScene(impl_->device);
  RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                         RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                         m.mesh.vertices.size()));
  for (size_t i = 0; i < m.mesh.vertices.size(); ++i) {
    for (int k = 0; k < 3; ++k) vb[3 * i + k] = static_cast<float>(m.mesh.vertices[i][k]);
  }
  auto* ib = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0,
                                                            RTC_FORMAT_UINT3, 3 * sizeof(uint32_t),
                                                            m.mesh.triangles.size()));
  for (size_t i = 0; i < m.mesh.triangles.size(); ++i) {
    for (int k = 0; k < 3; ++k) ib[3 * i + k] = static_cast<uint32_t>(m.mesh.triangles[i][k]);
  }
  rtcCommitGeometry(geom);
  rtcAttachGeometry(impl_->scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(impl_->device) != RTC_ERROR_NONE) {
    throw Error("deviation: Embree could not build the reference mesh's BVH");
  }
}

MeshDistance::~MeshDistance() {
  if (impl_->scene) rtcReleaseScene(impl_->scene);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

double MeshDistance::SignedDistance(const Eigen::Vector3d& p, double max_distance_mm,
                                    Eigen::Vector3d* closest) const {
  if (!p.allFinite()) return kNaN;
  Query q;
  q.mesh = &impl_->data;
  q.p = p;
  RTCPointQuery pq;
  pq.x = static_cast<float>(p.x());
  pq.y = static_cast<float>(p.y());
  pq.z = static_cast<float>(p.z());
  pq.time = 0;
  pq.radius = static_cast<float>(std::min(max_distance_mm, 1e30));
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  rtcPointQuery(impl_->scene, &pq, &context, QueryCallback, &q);
  if (!std::isfinite(q.best_sq) || q.best_sq > max_distance_mm * max_distance_mm) return kNaN;
  if (closest) *closest = q.closest;
  const double d = std::sqrt(q.best_sq);
  return (p - q.closest).dot(q.normal) < 0 ? -d : d;
}

void DeviationOptions::Check() const {
  util::CheckOption(max_distance_mm > 0, "DeviationOptions", "max_distance_mm", max_distance_mm,
                    "must be > 0");
}

std::string DeviationStats::BriefReport() const {
  return util::StrCat("deviation: ", points, " points (", unmatched, " farther than the limit), ",
                      "mean ", mean_mm, " mm, RMS ", rms_mm, " mm, 95% ", p95_mm, " mm, max ",
                      max_mm, " mm");
}

nlohmann::json ToJson(const DeviationStats& s) {
  return {{"points", s.points}, {"unmatched", s.unmatched}, {"mean_mm", s.mean_mm},
          {"rms_mm", s.rms_mm}, {"p95_mm", s.p95_mm},       {"max_mm", s.max_mm}};
}

DeviationStats DeviationFromMesh(const PointCloud& cloud, const MeshDistance& mesh,
                                 const DeviationOptions& options, std::vector<double>* signed_mm) {
  options.Check();
  std::vector<double> d(cloud.size(), kNaN);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, cloud.size(), 1024), [&](const auto& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      d[i] = mesh.SignedDistance(cloud.points[i], options.max_distance_mm);
    }
  });
  DeviationStats s;
  std::vector<double> abs_d;
  abs_d.reserve(d.size());
  double sum = 0, sum_sq = 0;
  for (size_t i = 0; i < d.size(); ++i) {
    if (!cloud.points[i].allFinite()) continue;
    if (!std::isfinite(d[i])) {
      ++s.unmatched;
      continue;
    }
    sum += d[i];
    sum_sq += d[i] * d[i];
    abs_d.push_back(std::abs(d[i]));
  }
  s.points = static_cast<int>(abs_d.size());
  if (s.points > 0) {
    s.mean_mm = sum / s.points;
    s.rms_mm = std::sqrt(sum_sq / s.points);
    const size_t k95 = std::min(abs_d.size() - 1, static_cast<size_t>(0.95 * abs_d.size()));
    std::nth_element(abs_d.begin(), abs_d.begin() + k95, abs_d.end());
    s.p95_mm = abs_d[k95];
    s.max_mm = *std::max_element(abs_d.begin(), abs_d.end());
  }
  if (signed_mm) *signed_mm = std::move(d);
  return s;
}

namespace {

cv::Vec3b Colour(double d, double range_mm) {
  if (!std::isfinite(d)) return cv::Vec3b(40, 40, 40);
  // Diverging map: blue (-range) -> green (0) -> red (+range), BGR.
  const double t = std::clamp(d / range_mm, -1.0, 1.0);
  if (t < 0)
    return cv::Vec3b(static_cast<uint8_t>(255 * -t), static_cast<uint8_t>(255 * (1 + t)), 0);
  return cv::Vec3b(0, static_cast<uint8_t>(255 * (1 - t)), static_cast<uint8_t>(255 * t));
}

}  // namespace

cv::Mat DeviationColorMap(int width, int height, const std::vector<double>& distances,
                          double range_mm) {
  util::CheckOption(range_mm > 0, "DeviationColorMap", "range_mm", range_mm, "must be > 0");
  if (distances.size() != static_cast<size_t>(width) * height) {
    throw Error(util::StrCat("DeviationColorMap: ", distances.size(), " values for a ", width, "x",
                             height, " grid"));
  }
  cv::Mat img(height, width, CV_8UC3);
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      img.at<cv::Vec3b>(r, c) = Colour(distances[static_cast<size_t>(r) * width + c], range_mm);
    }
  }
  return img;
}

cv::Mat DeviationColorMapTopView(const PointCloud& cloud, const std::vector<double>& distances,
                                 double range_mm, int max_size_px) {
  util::CheckOption(range_mm > 0, "DeviationColorMapTopView", "range_mm", range_mm, "must be > 0");
  Eigen::Vector3d mn, mx;
  cloud.Bounds(&mn, &mx);
  if (!mn.allFinite()) return cv::Mat(1, 1, CV_8UC3, cv::Scalar(40, 40, 40));
  const double extent = std::max({mx.x() - mn.x(), mx.y() - mn.y(), 1e-9});
  const double scale = (max_size_px - 1) / extent;
  const int w = static_cast<int>((mx.x() - mn.x()) * scale) + 1;
  const int h = static_cast<int>((mx.y() - mn.y()) * scale) + 1;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(40, 40, 40));
  cv::Mat depth(h, w, CV_64F, cv::Scalar(std::numeric_limits<double>::infinity()));
  for (size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points[i];
    if (!p.allFinite()) continue;
    const int c = static_cast<int>((p.x() - mn.x()) * scale);
    const int r = static_cast<int>((p.y() - mn.y()) * scale);
    if (p.z() < depth.at<double>(r, c)) {  // nearest to a viewer looking along +z
      depth.at<double>(r, c) = p.z();
      img.at<cv::Vec3b>(r, c) = Colour(distances[i], range_mm);
    }
  }
  return img;
}

}  // namespace fringe::eval
