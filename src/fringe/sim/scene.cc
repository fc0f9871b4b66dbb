#include "fringe/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "fringe/io/mesh_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Angular step (rad) whose chord stays within max_sag_mm of a circle of radius r.
int SegmentsForSag(double radius_mm, double max_sag_mm, double angle_rad) {
  const double c = std::clamp(1.0 - max_sag_mm / radius_mm, -1.0, 1.0);
  const double step = std::max(std::acos(c), 1e-4);
  return std::max(8, static_cast<int>(std::ceil(angle_rad / step)));
}

Eigen::Vector3d AnyPerpendicular(const Eigen::Vector3d& a) {
  const Eigen::Vector3d t =
      std::abs(a.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  return a.cross(t).normalized();
}

}  // namespace

// ---------------------------------------------------------------------------------------------

int Scene::AddObject(SceneObject object) {
  const std::string context = util::StrCat("scene object '", object.name, "'");
  object.mesh.Check(context);
  if (object.mesh.triangles.empty()) throw Error(context + ": mesh has no triangles");
  util::CheckOption(object.albedo >= 0 && object.albedo <= 1, "SceneObject", "albedo",
                    object.albedo, "must be in [0, 1]");
  if (object.sphere) {
    util::CheckOption(object.sphere->radius_mm > 0, "SceneObject", "sphere.radius_mm",
                      object.sphere->radius_mm, "must be > 0");
  }
  objects_.push_back(std::move(object));
  return static_cast<int>(objects_.size()) - 1;
}

const SceneObject* Scene::FindObject(const std::string& name) const {
  for (const auto& o : objects_) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

void Scene::AddMarker(const Marker& marker) {
  util::CheckOption(marker.inner_radius_mm > 0 && marker.inner_radius_mm < marker.outer_radius_mm,
                    "Marker", "inner_radius_mm", marker.inner_radius_mm,
                    "must be > 0 and < outer_radius_mm");
  Marker m = marker;
  m.normal_in_world.normalize();
  markers_.push_back(m);
}

TriangleMesh Scene::CombinedMesh() const {
  TriangleMesh all;
  for (const auto& o : objects_) all.Append(o.mesh);
  return all;
}

void Scene::Bounds(Eigen::Vector3d* min, Eigen::Vector3d* max) const {
  bool first = true;
  for (const auto& o : objects_) {
    Eigen::Vector3d a, b;
    o.mesh.Bounds(&a, &b);
    if (first) {
      *min = a;
      *max = b;
      first = false;
    } else {
      *min = min->cwiseMin(a);
      *max = max->cwiseMax(b);
    }
  }
  if (first) *min = *max = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
}

size_t Scene::NumTriangles() const {
  size_t n = 0;
  for (const auto& o : objects_) n += o.mesh.NumTriangles();
  return n;
}

// ---------------------------------------------------------------------------------------------

TriangleMesh MakeBoxMesh(const Eigen::Vector3d& min, const Eigen::Vector3d& max) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) {
    m.vertices.emplace_back((i & 1) ? max.x() : min.x(), (i & 2) ? max.y() : min.y(),
                            (i & 4) ? max.z() : min.z());
  }
  // Outward counter-clockwise faces.
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

TriangleMesh MakeRectangleMesh(const Eigen::Vector3d& centre, const Eigen::Vector3d& u,
                               const Eigen::Vector3d& v, double size_u, double size_v,
                               double max_edge_mm) {
  const int nu = std::max(1, static_cast<int>(std::ceil(size_u / max_edge_mm)));
  const int nv = std::max(1, static_cast<int>(std::ceil(size_v / max_edge_mm)));
  TriangleMesh m;
  for (int j = 0; j <= nv; ++j) {
    for (int i = 0; i <= nu; ++i) {
      m.vertices.push_back(centre + (size_u * (double(i) / nu - 0.5)) * u +
                           (size_v * (double(j) / nv - 0.5)) * v);
    }
  }
  for (int j = 0; j < nv; ++j) {
    for (int i = 0; i < nu; ++i) {
      const int a = j * (nu + 1) + i, b = a + 1, c = a + nu + 1, d = c + 1;
      m.triangles.push_back({a, b, d});
      m.triangles.push_back({a, d, c});
    }
  }
  return m;
}

TriangleMesh MakeSphereMesh(const Sphere& s, double max_sag_mm) {
  const int n_lon = SegmentsForSag(s.radius_mm, max_sag_mm, 2 * kPi);
  const int n_lat = std::max(4, n_lon / 2);
  TriangleMesh m;
  m.vertices.push_back(s.centre + Eigen::Vector3d(0, 0, -s.radius_mm));
  for (int j = 1; j < n_lat; ++j) {
    const double theta = kPi * j / n_lat - kPi / 2;
    for (int i = 0; i < n_lon; ++i) {
      const double phi = 2 * kPi * i / n_lon;
      m.vertices.push_back(s.centre + s.radius_mm * Eigen::Vector3d(std::cos(theta) * std::cos(phi),
                                                                    std::cos(theta) * std::sin(phi),
                                                                    std::sin(theta)));
    }
  }
  const int top = static_cast<int>(m.vertices.size());
  m.vertices.push_back(s.centre + Eigen::Vector3d(0, 0, s.radius_mm));
  auto ring = [&](int j, int i) { return 1 + (j - 1) * n_lon + (i % n_lon); };
  for (int i = 0; i < n_lon; ++i) m.triangles.push_back({0, ring(1, i + 1), ring(1, i)});
  for (int j = 1; j < n_lat - 1; ++j) {
    for (int i = 0; i < n_lon; ++i) {
      m.triangles.push_back({ring(j, i), ring(j, i + 1), ring(j + 1, i + 1)});
      m.triangles.push_back({ring(j, i), ring(j + 1, i + 1), ring(j + 1, i)});
    }
  }
  for (int i = 0; i < n_lon; ++i) {
    m.triangles.push_back({top, ring(n_lat - 1, i), ring(n_lat - 1, i + 1)});
  }
  return m;
}

TriangleMesh MakeCylinderMesh(const Eigen::Vector3d& base, const Eigen::Vector3d& axis_in,
                              double radius_mm, double length_mm, double max_sag_mm) {
  const Eigen::Vector3d axis = axis_in.normalized();
  const Eigen::Vector3d u = AnyPerpendicular(axis);
  const Eigen::Vector3d v = axis.cross(u);
  const int n = SegmentsForSag(radius_mm, max_sag_mm, 2 * kPi);
  TriangleMesh m;
  for (int end = 0; end < 2; ++end) {
    for (int i = 0; i < n; ++i) {
      const double phi = 2 * kPi * i / n;
      m.vertices.push_back(base + end * length_mm * axis +
                           radius_mm * (std::cos(phi) * u + std::sin(phi) * v));
    }
  }
  const int c0 = static_cast<int>(m.vertices.size());
  m.vertices.push_back(base);
  m.vertices.push_back(base + length_mm * axis);
  for (int i = 0; i < n; ++i) {
    const int a = i, b = (i + 1) % n, c = n + i, d = n + (i + 1) % n;
    m.triangles.push_back({a, b, d});
    m.triangles.push_back({a, d, c});
    m.triangles.push_back({c0, b, a});
    m.triangles.push_back({c0 + 1, c, d});
  }
  return m;
}

// ---------------------------------------------------------------------------------------------

namespace {

SceneObject BasePlate(double size_x, double size_y, double thickness, const Eigen::Vector3d& c) {
  SceneObject plate;
  plate.name = "base_plate";
  plate.albedo = 0.55;
  plate.mesh = MakeBoxMesh(c + Eigen::Vector3d(-size_x / 2, -size_y / 2, -thickness),
                           c + Eigen::Vector3d(size_x / 2, size_y / 2, 0));
  return plate;
}

SceneObject SphereObject(const std::string& name, const Sphere& s) {
  SceneObject o;
  o.name = name;
  o.albedo = 0.75;
  o.sphere = s;
  o.mesh = MakeSphereMesh(s, 5e-3);
  return o;
}

}  // namespace

Scene MakeSphereScene(double radius_mm, bool with_plate) {
  Scene scene;
  Sphere s;
  s.radius_mm = radius_mm;
  s.centre = with_plate ? Eigen::Vector3d(0, 0, radius_mm) : Eigen::Vector3d::Zero();
  scene.AddObject(SphereObject("sphere", s));
  if (with_plate) scene.AddObject(BasePlate(200, 160, 10, Eigen::Vector3d::Zero()));
  return scene;
}

Scene MakeBallBarScene(double sphere_radius_mm, double centre_distance_mm) {
  Scene scene;
  const double z = 40;
  Sphere a{Eigen::Vector3d(-centre_distance_mm / 2, 0, z), sphere_radius_mm};
  Sphere b{Eigen::Vector3d(centre_distance_mm / 2, 0, z), sphere_radius_mm};
  scene.AddObject(SphereObject("sphere_a", a));
  scene.AddObject(SphereObject("sphere_b", b));
  SceneObject bar;
  bar.name = "bar";
  bar.albedo = 0.15;
  // The bar ends inside the spheres, so their visible surface stays spherical.
  const double bar_radius = std::min(4.0, 0.3 * sphere_radius_mm);
  bar.mesh =
      MakeCylinderMesh(a.centre, Eigen::Vector3d::UnitX(), bar_radius, centre_distance_mm, 5e-3);
  scene.AddObject(bar);
  SceneObject post;
  post.name = "post";
  post.albedo = 0.15;
  post.mesh = MakeCylinderMesh(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d::UnitZ(), 6.0, z, 5e-3);
  scene.AddObject(post);
  scene.AddObject(
      BasePlate(centre_distance_mm + 4 * sphere_radius_mm + 40, 120, 10, Eigen::Vector3d::Zero()));
  return scene;
}

Scene MakePlateScene(double length_mm, double width_mm) {
  Scene scene;
  SceneObject plate;
  plate.name = "plate";
  plate.albedo = 0.8;
  plate.mesh = MakeBoxMesh(Eigen::Vector3d(-length_mm / 2, -width_mm / 2, -15),
                           Eigen::Vector3d(length_mm / 2, width_mm / 2, 0));
  scene.AddObject(plate);
  return scene;
}

Scene MakePlaneScene(double size_mm) {
  Scene scene;
  SceneObject plane;
  plane.name = "plane";
  plane.albedo = 0.8;
  plane.mesh = MakeRectangleMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                 Eigen::Vector3d::UnitY(), size_mm, size_mm);
  scene.AddObject(plane);
  return scene;
}

Scene MakeVdiScene() {
  Scene scene;
  scene.AddObject(SphereObject("sphere", Sphere{Eigen::Vector3d(-60, -45, 15), 15.0}));
  const double z = 30;
  Sphere a{Eigen::Vector3d(-75, 35, z), 10.0};
  Sphere b{Eigen::Vector3d(75, 35, z), 10.0};
  scene.AddObject(SphereObject("sphere_a", a));
  scene.AddObject(SphereObject("sphere_b", b));
  SceneObject bar;
  bar.name = "bar";
  bar.albedo = 0.15;
  bar.mesh = MakeCylinderMesh(a.centre, Eigen::Vector3d::UnitX(), 3.0, 150.0, 5e-3);
  scene.AddObject(bar);
  SceneObject plate;
  plate.name = "plate";
  plate.albedo = 0.8;
  plate.mesh = MakeBoxMesh(Eigen::Vector3d(-10, -70, 0), Eigen::Vector3d(110, -20, 12));
  scene.AddObject(plate);
  scene.AddObject(BasePlate(260, 180, 10, Eigen::Vector3d::Zero()));
  return scene;
}

Scene MakeMeshScene(const std::filesystem::path& path) {
  Scene scene;
  SceneObject o;
  o.name = path.stem().string();
  o.mesh = io::ReadMesh(path);
  scene.AddObject(std::move(o));
  return scene;
}

}  // namespace fringe::sim
