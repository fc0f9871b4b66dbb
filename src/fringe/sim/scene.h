// Scenes for the virtual scanner: triangle meshes with a diffuse albedo, exact analytic spheres,
// and sticky markers.
//
// Frames and units: every scene lives in its own world frame, in millimetres, z up (parts rest on
// the plane z = 0 of a base plate where there is one). Meshes are stored in world coordinates.
//
// Geometry the renderer sees: the triangles of every object (ray cast with Embree). An object may
// also carry an exact sphere: its mesh is then an inscribed tessellation used only to find the
// hit, and the hit point and normal are recomputed on the true sphere in double precision, so
// VDI/VDE 2634-2 sphere tests are not limited by tessellation (silhouette slivers thinner than
// the tessellation sag, ~1 um by default, are the only difference).
//
// Markers are stickers: a white disk inside a black ring, rendered as albedo on whatever surface
// lies within the ring radius of their centre (measured in their tangent plane), so they conform
// to the surface. Their centres lie on the surface and are ground truth.
//
// Thread safety: a Scene is immutable while renderers use it (renderers keep their own copy).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/geometry/triangle_mesh.h"
#include "fringe/scan/truth.h"

namespace fringe::sim {

// Diffuse reflectance in [0, 1] at a surface point (world frame, mm). Must be thread safe.
using AlbedoFunction = std::function<double(const Eigen::Vector3d& p_in_world)>;

struct Sphere {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // world frame, mm
  double radius_mm = 10;
};

struct SceneObject {
  std::string name;
  TriangleMesh mesh;       // world frame
  double albedo = 0.7;     // diffuse reflectance in [0, 1], used when `texture` is empty
  AlbedoFunction texture;  // optional albedo texture (overrides `albedo`)
  // When set, `mesh` is an inscribed tessellation of this sphere and hits are refined onto it.
  std::optional<Sphere> sphere;
};

// Markers are the scan folder's truth records (scan/truth.h): the same type in the scene, the
// renderer and truth/markers.json.
using Marker = scan::Marker;

class Scene {
 public:
  // Returns the object's index. Throws fringe::Error for a bad mesh or albedo.
  int AddObject(SceneObject object);
  const std::vector<SceneObject>& objects() const { return objects_; }
  const SceneObject& object(int i) const { return objects_.at(i); }
  // The first object with this name, or nullptr.
  const SceneObject* FindObject(const std::string& name) const;

  void AddMarker(const Marker& marker);
  const std::vector<Marker>& markers() const { return markers_; }
  void ClearMarkers() { markers_.clear(); }

  double marker_white_albedo = 0.92;  // albedo of a marker's white disk, [0, 1]
  double marker_black_albedo = 0.03;  // albedo of a marker's black ring, [0, 1]

  // All objects' triangles in one mesh (world frame), e.g. for truth/scene.ply.
  TriangleMesh CombinedMesh() const;
  void Bounds(Eigen::Vector3d* min, Eigen::Vector3d* max) const;
  size_t NumTriangles() const;

 private:
  std::vector<SceneObject> objects_;
  std::vector<Marker> markers_;
};

// ---- Meshes of primitives (world frame) ----

// Axis-aligned box [min, max].
TriangleMesh MakeBoxMesh(const Eigen::Vector3d& min, const Eigen::Vector3d& max);
// Rectangle centred at `centre` spanned by unit axes u, v (normal u x v), size_u x size_v mm,
// split into a grid of cells so that no triangle is longer than max_edge_mm.
TriangleMesh MakeRectangleMesh(const Eigen::Vector3d& centre, const Eigen::Vector3d& u,
                               const Eigen::Vector3d& v, double size_u, double size_v,
                               double max_edge_mm = 50);
// Sphere tessellation inscribed in the true sphere, fine enough that no point of the mesh is
// farther than max_sag_mm from it.
TriangleMesh MakeSphereMesh(const Sphere& sphere, double max_sag_mm = 1e-3);
// Closed cylinder from `base` along unit `axis`, with end caps; max_sag_mm as above.
TriangleMesh MakeCylinderMesh(const Eigen::Vector3d& base, const Eigen::Vector3d& axis,
                              double radius_mm, double length_mm, double max_sag_mm = 1e-3);

// ---- Ready-made scenes (z up, resting on or centred near the world origin) ----

// VDI/VDE 2634-2 matte sphere (albedo 0.75) centred at (0, 0, radius) on a plate at z = 0,
// or floating at the origin when with_plate is false.
Scene MakeSphereScene(double radius_mm = 15.0, bool with_plate = true);
// Ball bar: two matte spheres (objects "sphere_a", "sphere_b") `centre_distance_mm` apart along
// x, centred at z = 40 mm, joined by a dark bar; a plate at z = 0 beneath.
Scene MakeBallBarScene(double sphere_radius_mm = 12.5, double centre_distance_mm = 200.0);
// Flat plate (object "plate") 220 x 60 x 15 mm, its measured top face at z = 0.
Scene MakePlateScene(double length_mm = 220.0, double width_mm = 60.0);
// A single large plane z = 0 (object "plane"), 400 x 400 mm.
Scene MakePlaneScene(double size_mm = 400.0);
// The VDI set in one scene: sphere, ball bar and plate side by side.
Scene MakeVdiScene();
// A mesh file (io::ReadMesh: .ply, .obj, .stl) as one object (albedo 0.7) on no plate.
Scene MakeMeshScene(const std::filesystem::path& path);

}  // namespace fringe::sim
