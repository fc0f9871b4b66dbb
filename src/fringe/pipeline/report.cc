#include "fringe/pipeline/report.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include <tbb/parallel_for.h>

#include "fringe/sim/ray_caster.h"
#include "fringe/sim/scene.h"
#include "fringe/util/error.h"

namespace fringe::pipeline {

struct MeshRenderer::Impl {
  std::unique_ptr<sim::RayCaster> caster;  // null for an empty mesh
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 1;
};

MeshRenderer::MeshRenderer(const TriangleMesh& mesh)
    : mesh_(mesh), impl_(std::make_unique<Impl>()) {
  if (mesh.vertices.empty() || mesh.triangles.empty()) return;
  sim::SceneObject object;
  object.name = "mesh";
  object.mesh.vertices = mesh.vertices;
  object.mesh.triangles = mesh.triangles;
  sim::Scene scene;
  scene.AddObject(std::move(object));
  impl_->caster = std::make_unique<sim::RayCaster>(scene);
  Eigen::Vector3d lo, hi;
  scene.Bounds(&lo, &hi);
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
  const sim::RayCaster& caster = *impl_->caster;
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
  Cast(view_dir, width_px, height_px, [&](int r, int c, const sim::Hit&, double shade) {
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
  Cast(view_dir, width_px, height_px, [&](int r, int c, const sim::Hit& hit, double shade) {
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

}  // namespace fringe::pipeline
