#include "fringe/pipeline/report.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>

#include <tbb/parallel_for.h>

#include "fringe/fusion/mesh.h"
#include "fringe/geometry/mesh_index.h"
#include "fringe/geometry/point_index.h"
#include "fringe/util/error.h"

namespace fringe::pipeline {

struct MeshRenderer::Impl {
  // kHigh: a picture casts a ray per pixel, where spatial splits pay for their longer build.
  std::unique_ptr<MeshIndex> caster;  // null for an empty mesh
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 1;
};

MeshRenderer::MeshRenderer(const TriangleMesh& mesh)
    : mesh_(mesh), impl_(std::make_unique<Impl>()) {
  if (mesh.vertices.empty() || mesh.triangles.empty()) return;
  TriangleMesh surface;
  surface.vertices = mesh.vertices;
  surface.triangles = mesh.triangles;
  impl_->caster = std::make_unique<MeshIndex>(std::move(surface), BvhQuality::kHigh);
  Eigen::Vector3d lo, hi;
  mesh.Bounds(&lo, &hi);
  impl_->centre = 0.5 * (lo + hi);
  impl_->radius = std::max(1e-9, 0.5 * (hi - lo).norm());
}

MeshRenderer::~MeshRenderer() = default;

// Casts one orthographic ray per pixel at the mesh (its bounding sphere fills the shorter side)
// and hands each hit with its Lambert shade in [0, 1] to `paint`. Rows run in parallel: every
// pixel is its own ray and `paint` writes only its pixel, so the picture does not depend on the
// thread count.
template <typename Paint>
void MeshRenderer::Cast(const Eigen::Vector3d& view_dir, int width_px, int height_px,
                        Paint paint) const {
  if (!impl_->caster) return;
  const MeshIndex& caster = *impl_->caster;
  const Eigen::Vector3d& centre = impl_->centre;
  const double radius = impl_->radius;
  // Camera frame: d forward, u right, v down (image rows), with the mesh frame's z up on the
  // picture unless the view looks along z.
  const Eigen::Vector3d d = view_dir.normalized();
  const Eigen::Vector3d up =
      std::abs(d.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d u = d.cross(up).normalized();
  const Eigen::Vector3d v = d.cross(u).normalized();
  const double scale = 2.1 * radius / std::min(width_px, height_px);  // mm per pixel
  // Light from over the viewer's left shoulder, so relief reads naturally.
  const Eigen::Vector3d to_light = (-d - 0.5 * u - 0.5 * v).normalized();
  tbb::parallel_for(0, height_px, [&](int r) {
    for (int c = 0; c < width_px; ++c) {
      const Eigen::Vector3d origin = centre - 2 * radius * d +
                                     (c - 0.5 * (width_px - 1)) * scale * u +
                                     (r - 0.5 * (height_px - 1)) * scale * v;
      const auto hit = caster.Cast(origin, d);
      if (!hit) continue;
      Eigen::Vector3d n = hit->normal;
      if (n.dot(d) > 0) n = -n;  // both faces lit: open meshes show their inside as well
      paint(r, c, *hit, 0.15 + 0.85 * std::max(0.0, n.dot(to_light)));
    }
  });
}

cv::Mat MeshRenderer::Render(const Eigen::Vector3d& view_dir, int width_px, int height_px) const {
  CV_Assert(width_px > 0 && height_px > 0);
  cv::Mat image(height_px, width_px, CV_8U, cv::Scalar(0));
  Cast(view_dir, width_px, height_px, [&](int r, int c, const MeshHit&, double shade) {
    image.at<uint8_t>(r, c) = static_cast<uint8_t>(std::lround(40 + 215 * shade));
  });
  return image;
}

cv::Mat MeshRenderer::RenderColoured(const std::vector<double>& vertex_values, double lo, double hi,
                                     const std::string& unit, const Eigen::Vector3d& view_dir,
                                     int width_px, int height_px) const {
  CV_Assert(width_px > 24 && height_px > 0 && hi > lo);
  const TriangleMesh& mesh = mesh_;
  if (vertex_values.size() != mesh.vertices.size()) {
    throw Error(util::StrCat("report: ", vertex_values.size(), " vertex values for a mesh of ",
                             mesh.vertices.size(), " vertices"));
  }
  cv::Mat image(height_px, width_px, CV_8UC3, cv::Scalar(0, 0, 0));
  // The colour of a value: one turbo lookup table, applied per hit.
  cv::Mat ramp(1, 256, CV_8U), lut;
  for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(0, i) = static_cast<uint8_t>(i);
  cv::applyColorMap(ramp, lut, cv::COLORMAP_TURBO);
  Cast(view_dir, width_px, height_px, [&](int r, int c, const MeshHit& hit, double shade) {
    // Barycentric interpolation of the hit triangle's vertex values.
    const auto& t = mesh.triangles[static_cast<size_t>(hit.triangle)];
    const Eigen::Vector3d &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]],
                          &p = mesh.vertices[t[2]];
    const Eigen::Vector3d n = (b - a).cross(p - a);
    const double area = n.squaredNorm();
    double value = std::numeric_limits<double>::quiet_NaN();
    if (area > 0) {
      const double wb = (hit.point - a).cross(p - a).dot(n) / area;
      const double wc = (b - a).cross(hit.point - a).dot(n) / area;
      value =
          (1 - wb - wc) * vertex_values[t[0]] + wb * vertex_values[t[1]] + wc * vertex_values[t[2]];
    }
    cv::Vec3b colour(150, 150, 150);
    if (std::isfinite(value)) {
      const int k = static_cast<int>(std::clamp((value - lo) / (hi - lo), 0.0, 1.0) * 255);
      colour = lut.at<cv::Vec3b>(0, k);
    }
    const double s = 0.35 + 0.65 * shade;
    image.at<cv::Vec3b>(r, c) = cv::Vec3b(cv::saturate_cast<uint8_t>(colour[0] * s),
                                          cv::saturate_cast<uint8_t>(colour[1] * s),
                                          cv::saturate_cast<uint8_t>(colour[2] * s));
  });
  cv::Mat out;
  cv::vconcat(image, ColourBar(width_px, lo, hi, unit), out);
  return out;
}

cv::Mat RenderMesh(const TriangleMesh& mesh, const Eigen::Vector3d& view_dir, int width_px,
                   int height_px) {
  return MeshRenderer(mesh).Render(view_dir, width_px, height_px);
}

cv::Mat RenderMeshColoured(const TriangleMesh& mesh, const std::vector<double>& vertex_values,
                           double lo, double hi, const std::string& unit,
                           const Eigen::Vector3d& view_dir, int width_px, int height_px) {
  if (vertex_values.size() != mesh.vertices.size()) {
    throw Error(util::StrCat("report: ", vertex_values.size(), " vertex values for a mesh of ",
                             mesh.vertices.size(), " vertices"));
  }
  return MeshRenderer(mesh).RenderColoured(vertex_values, lo, hi, unit, view_dir, width_px,
                                           height_px);
}

void ScanSceneOptions::Check() const {
  util::CheckOption(max_triangles >= 4, "ScanSceneOptions", "max_triangles", max_triangles,
                    "must be >= 4");
  util::CheckOption(max_points >= 0, "ScanSceneOptions", "max_points", max_points, "must be >= 0");
}

namespace {

// Every k-th index so that at most max_count of n remain.
std::vector<size_t> Sample(size_t n, size_t max_count) {
  std::vector<size_t> out;
  if (max_count == 0) return out;
  const size_t step = std::max<size_t>(1, (n + max_count - 1) / max_count);
  for (size_t i = 0; i < n; i += step) out.push_back(i);
  return out;
}

nlohmann::json Row(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// 3 x 4, row-major.
nlohmann::json Matrix34(const Rigid3d& t) {
  const Eigen::Matrix3d r = t.rotation().toRotationMatrix();
  nlohmann::json out = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out.push_back(r(i, j));
    out.push_back(t.translation()(i));
  }
  return out;
}

}  // namespace

ReportScene ScanScene(const ScanSceneInput& in, const ScanSceneOptions& options) {
  options.Check();
  const bool has_mesh = in.mesh && !in.mesh->triangles.empty();
  const bool has_points = in.fused && !in.fused->empty();
  if (has_mesh && in.mesh_deviation_mm && !in.mesh_deviation_mm->empty() &&
      in.mesh_deviation_mm->size() != in.mesh->vertices.size()) {
    throw Error(util::StrCat("report scene: ", in.mesh_deviation_mm->size(),
                             " deviations for a mesh of ", in.mesh->vertices.size(), " vertices"));
  }
  for (const auto* per_point : {in.fused_support, in.fused_view}) {
    if (has_points && per_point && !per_point->empty() && per_point->size() != in.fused->size()) {
      throw Error(util::StrCat("report scene: ", per_point->size(), " values for ",
                               in.fused->size(), " fused points"));
    }
  }
  ReportScene scene;
  nlohmann::json& d = scene.description;
  d["version"] = 1;
  d["frame"] = "world frame of mesh.ply, mm";
  d["display_from_world"] = Matrix34(in.display_from_world);

  // Positions are float32 relative to an origin near the model (float32 keeps 0.1 um there).
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  if (has_mesh) in.mesh->Bounds(&lo, &hi);
  if (!has_mesh && has_points) in.fused->Bounds(&lo, &hi);
  const Eigen::Vector3d origin = lo.allFinite() && hi.allFinite()
                                     ? Eigen::Vector3d((0.5 * (lo + hi)).array().round())
                                     : Eigen::Vector3d::Zero();
  d["origin"] = Row(origin);
  const auto positions = [&](const std::vector<Eigen::Vector3d>& points,
                             const std::vector<size_t>* ids) {
    const size_t n = ids ? ids->size() : points.size();
    std::vector<float> out(3 * n);
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d p = points[ids ? (*ids)[i] : i] - origin;
      for (int k = 0; k < 3; ++k) out[3 * i + k] = static_cast<float>(p(k));
    }
    return out;
  };

  // Sensors: the views' names index the "view" colouring (and the report's tables).
  std::map<std::string, uint16_t> sensor_index;
  d["views"] = nlohmann::json::array();
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  for (const ScanSceneInput::Sensor& sn : in.sensors) {
    sensor_index.emplace(sn.name, static_cast<uint16_t>(sensor_index.size()));
    const double distance =
        centre.allFinite() ? (sn.world_from_sensor.translation() - centre).norm() : 100.0;
    const CameraModel& c = sn.camera;
    d["views"].push_back({{"name", sn.name},
                          {"world_from_sensor", Matrix34(sn.world_from_sensor)},
                          {"fx", c.fx},
                          {"fy", c.fy},
                          {"cx", c.cx},
                          {"cy", c.cy},
                          {"width", c.width},
                          {"height", c.height},
                          {"depth_mm", 0.2 * distance}});
  }
  // The fused points' views as sensor indices (65535: a view without a sensor).
  constexpr uint16_t kNoView = 65535;
  std::vector<uint16_t> view_of_fusion_view;
  for (const std::string& name : in.fused_view_names) {
    const auto it = sensor_index.find(name);
    view_of_fusion_view.push_back(it == sensor_index.end() ? kNoView : it->second);
  }
  const auto point_view = [&](size_t i) -> uint16_t {
    if (!in.fused_view || in.fused_view->empty()) return kNoView;
    const uint16_t f = (*in.fused_view)[i];
    return f < view_of_fusion_view.size() ? view_of_fusion_view[f] : kNoView;
  };
  const bool has_view = has_points && in.fused_view && !in.fused_view->empty();
  const bool has_support = has_points && in.fused_support && !in.fused_support->empty();
  const bool has_quality = has_points && in.fused->has_quality();

  // The fused points: a sample to show, and (a larger one) to colour the mesh's vertices by.
  std::unique_ptr<PointIndex> point_index;
  std::vector<size_t> index_ids;
  if (has_points) {
    const std::vector<size_t> ids = Sample(in.fused->size(), size_t(options.max_points));
    std::vector<float> quality;
    std::vector<uint16_t> support, view;
    for (size_t i : ids) {
      if (has_quality) quality.push_back(in.fused->quality[i]);
      if (has_support) support.push_back((*in.fused_support)[i]);
      if (has_view) view.push_back(point_view(i));
    }
    if (!ids.empty()) {
      scene.AddArray("points.positions", positions(in.fused->points, &ids));
      nlohmann::json points = {
          {"positions", "points.positions"}, {"count", ids.size()}, {"total", in.fused->size()}};
      if (has_view) {
        scene.AddArray("points.view", view);
        points["view"] = "points.view";
      }
      if (has_quality) scene.AddArray("points.quality", quality);
      if (has_support) scene.AddArray("points.support", support);
      d["points"] = points;
    }
    if (has_mesh && (has_view || has_support || has_quality)) {
      index_ids = Sample(in.fused->size(), 400000);
      std::vector<Eigen::Vector3d> p;
      p.reserve(index_ids.size());
      for (size_t i : index_ids) p.push_back(in.fused->points[i]);
      point_index = std::make_unique<PointIndex>(std::move(p));
    }
  }

  if (has_mesh) {
    std::vector<int64_t> source;  // per shown vertex: the vertex of the full mesh it is
    const TriangleMesh shown = fusion::DecimateMesh(*in.mesh, options.max_triangles, &source);
    const size_t n = shown.vertices.size();
    std::vector<uint32_t> indices;
    indices.reserve(3 * shown.triangles.size());
    for (const TriangleMesh::Triangle& t : shown.triangles) {
      for (int32_t v : t) indices.push_back(static_cast<uint32_t>(v));
    }
    scene.AddArray("mesh.positions", positions(shown.vertices, nullptr));
    scene.AddArray("mesh.indices", indices);
    nlohmann::json mesh = {{"positions", "mesh.positions"},
                           {"indices", "mesh.indices"},
                           {"vertices", n},
                           {"triangles", shown.triangles.size()},
                           {"full_triangles", in.mesh->triangles.size()}};
    if (in.mesh_deviation_mm && !in.mesh_deviation_mm->empty()) {
      // Deviation: that of the same vertex of the full mesh (decimation keeps vertices).
      std::vector<float> deviation(n);
      for (size_t v = 0; v < n; ++v) {
        deviation[v] = static_cast<float>((*in.mesh_deviation_mm)[size_t(source[v])]);
      }
      scene.AddArray("mesh.deviation", deviation);
    }
    if (point_index) {
      std::vector<uint16_t> view(n, kNoView), support(n, 0);
      std::vector<float> quality(n, std::numeric_limits<float>::quiet_NaN());
      tbb::parallel_for(size_t{0}, n, [&](size_t v) {
        const size_t i = index_ids[point_index->Nearest(shown.vertices[v]).first];
        if (has_view) view[v] = point_view(i);
        if (has_support) support[v] = (*in.fused_support)[i];
        if (has_quality) quality[v] = in.fused->quality[i];
      });
      if (has_view) {
        scene.AddArray("mesh.view", view);
        mesh["view"] = "mesh.view";
      }
      if (has_support) scene.AddArray("mesh.support", support);
      if (has_quality) scene.AddArray("mesh.quality", quality);
    }
    d["mesh"] = mesh;
  }

  // The colourings, the first the default: deviation when there is one, else height.
  nlohmann::json colourings = nlohmann::json::array();
  const nlohmann::json& arrays = d["arrays"];
  const auto named = [&](const std::string& name) {
    return arrays.contains(name) ? nlohmann::json(name) : nlohmann::json(nullptr);
  };
  if (arrays.contains("mesh.deviation")) {
    colourings.push_back({{"id", "deviation"},
                          {"title", "signed deviation"},
                          {"label", in.deviation_range.Legend(in.deviation_what)},
                          {"kind", "signed"},
                          {"unit", "mm"},
                          {"range", {in.deviation_range.lo(), in.deviation_range.hi()}},
                          {"mesh", "mesh.deviation"}});
  }
  colourings.push_back({{"id", "height"},
                        {"title", "height"},
                        {"label", "height (z up, as in the pictures), mm"},
                        {"kind", "height"},
                        {"unit", "mm"}});
  if (has_view) {
    nlohmann::json names = nlohmann::json::array();
    for (const ScanSceneInput::Sensor& sn : in.sensors) names.push_back(sn.name);
    colourings.push_back({{"id", "view"},
                          {"title", "view"},
                          {"label", "the view a point came from (fusion: its cluster's seed)"},
                          {"kind", "category"},
                          {"names", names},
                          {"mesh", named("mesh.view")},
                          {"points", named("points.view")}});
  }
  if (has_support) {
    uint16_t most = 1;
    for (uint16_t k : *in.fused_support) most = std::max(most, k);
    colourings.push_back({{"id", "support"},
                          {"title", "fusion support"},
                          {"label", "fusion support: views merged into the point"},
                          {"kind", "scalar"},
                          {"unit", "views"},
                          {"range", {1, std::max<int>(2, most)}},
                          {"mesh", named("mesh.support")},
                          {"points", named("points.support")}});
  }
  if (has_quality) {
    colourings.push_back({{"id", "quality"},
                          {"title", "fusion quality"},
                          {"label", "fusion quality: weighted fringe modulation, DN"},
                          {"kind", "scalar"},
                          {"unit", "DN"},
                          {"mesh", named("mesh.quality")},
                          {"points", named("points.quality")}});
  }
  d["colourings"] = colourings;

  d["markers"] = nlohmann::json::array();
  for (const ScanSceneInput::Marker& mk : in.markers) {
    d["markers"].push_back({{"id", mk.id},
                            {"centre", Row(mk.centre_in_world)},
                            {"radius_mm", mk.radius_mm},
                            {"views", mk.views}});
  }
  return scene;
}

}  // namespace fringe::pipeline
