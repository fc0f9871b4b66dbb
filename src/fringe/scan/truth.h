// Ground truth of a simulated scan as the scan folder stores it (docs/scan-folder.md, truth/):
// the sensor pose of every view, the markers and where they project, and the scene's objects.
// The simulator writes these records (sim/scan.cc) and its scene and renderer use the same
// marker types; registration, fusion and their benchmarks read them back to compare against.
//
// Frames and units: millimetres; `world_from_sensor` maps the left camera frame of a view to the
// world (docs/conventions.md); pixel positions with the centre of the top-left pixel at (0, 0).
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fringe/geometry/rigid3.h"

namespace fringe::scan {

// A sticker marker: a white disk (inner radius) inside a black ring (outer radius), conforming
// to the surface; its centre lies on the surface.
struct Marker {
  int id = 0;
  Eigen::Vector3d centre_in_world = Eigen::Vector3d::Zero();   // on the surface, mm
  Eigen::Vector3d normal_in_world = Eigen::Vector3d::UnitZ();  // outward unit surface normal
  double inner_radius_mm = 1.5;                                // white disk radius
  double outer_radius_mm = 2.5;                                // black ring outer radius
};

// Where a marker's centre is in one view. left_px / right_px are the TRUE projections of the
// centre (not ellipse centres), NaN when the centre is behind that camera.
struct MarkerObservation {
  int id = 0;
  Eigen::Vector3d centre_in_sensor = Eigen::Vector3d::Zero();  // left camera frame, mm
  Eigen::Vector2d left_px = Eigen::Vector2d::Zero();           // true projected centre (left image)
  Eigen::Vector2d right_px = Eigen::Vector2d::Zero();  // true projected centre (right image)
  bool visible_left = false;  // in image, facing the camera and not occluded
  bool visible_right = false;
};

// truth/poses.json, and fringe register's DIR/poses.json (the same schema plus "format":
// "fringe-poses" and "version": 1, which the reader checks when present): the one poses reader
// of the project (registration --initial, fuse --poses, benchmarks).
struct ViewPose {
  std::string view;  // view folder name, "000"
  Rigid3d world_from_sensor;
};
struct TruthPoses {
  bool turntable = false;  // the part turned, the sensor stayed (world = the part's frame)
  std::vector<ViewPose> views;
  // The pose of a view by name, or nullptr.
  const ViewPose* Find(const std::string& view) const;
  // world_from_sensor by view name.
  std::map<std::string, Rigid3d> ByView() const;
};

// truth/markers.json
struct ViewMarkers {
  std::string view;
  std::vector<MarkerObservation> observations;
};
struct TruthMarkers {
  std::vector<Marker> markers;
  std::vector<ViewMarkers> views;
  const ViewMarkers* Find(const std::string& view) const;
};

// truth/scene.json
struct TruthSphere {
  Eigen::Vector3d centre_in_world = Eigen::Vector3d::Zero();
  double radius_mm = 0;
};
struct TruthObject {
  std::string name;
  std::optional<double> albedo;  // absent for textured objects
  size_t triangles = 0;
  std::optional<TruthSphere> sphere;  // the object is this exact sphere
};
struct TruthScene {
  std::string scene;               // scene name
  std::string mesh = "scene.ply";  // the triangles, relative to truth/
  std::vector<TruthObject> objects;
  // The first object with this name, or nullptr.
  const TruthObject* Find(const std::string& name) const;
};

// JSON forms (docs/scan-folder.md). The readers validate: missing or mistyped fields, duplicate
// views, non-finite numbers and non-positive radii throw fringe::Error naming `context` (the
// file) and the field.
nlohmann::json PosesToJson(const TruthPoses& poses);
TruthPoses PosesFromJson(const nlohmann::json& j, const std::string& context);
nlohmann::json MarkersToJson(const TruthMarkers& markers);
TruthMarkers MarkersFromJson(const nlohmann::json& j, const std::string& context);
nlohmann::json SceneToJson(const TruthScene& scene);
TruthScene SceneFromJson(const nlohmann::json& j, const std::string& context);

// Files (written atomically; read with the file named in every error).
void WriteTruthPoses(const std::filesystem::path& path, const TruthPoses& poses);
TruthPoses ReadTruthPoses(const std::filesystem::path& path);
void WriteTruthMarkers(const std::filesystem::path& path, const TruthMarkers& markers);
TruthMarkers ReadTruthMarkers(const std::filesystem::path& path);
void WriteTruthScene(const std::filesystem::path& path, const TruthScene& scene);
TruthScene ReadTruthScene(const std::filesystem::path& path);

}  // namespace fringe::scan
