// Simulated scans written as scan folders (docs/scan-folder.md): fringe images of every view,
// calibration board images, and the complete ground truth.
//
// Scenes by name: "demo" (MakeDemoPart), "board" (the calibration target lying flat as a scene
// object, for projector calibration or flatness), "sphere", "ballbar", "plane", "plate", "vdi",
// or "mesh:FILE" (.ply, .obj, .stl). World frame z up; the sensor orbits the scene (or the scene
// turns on a turntable) at the rig's working distance.
//
// Deterministic for a seed; independent of the thread count (renderer.h).
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fringe/geometry/calibration_target.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/sim/board.h"
#include "fringe/sim/demo_part.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scene.h"

namespace fringe::sim {

// Names accepted by MakeSceneByName (mesh:FILE aside).
std::vector<std::string> SceneNames();

// A scene from its name (see above). The demo part's markers use `seed`. Throws fringe::Error
// for an unknown name or an unreadable mesh.
Scene MakeSceneByName(const std::string& name, uint64_t seed = 1);

// The calibration target lying on the plane z = 0 of the world, centred at the origin, as a
// scene object "board" textured with its printed pattern (on a slightly larger grey panel).
Scene MakeBoardScene(const CalibrationTarget& target = CalibrationTarget::Reference());

struct ScanOptions {
  std::string scene = "demo";  // a scene name (MakeSceneByName)
  int views = 6;               // fringe views, >= 0
  uint64_t seed = 1;           // scene markers, poses, board poses, noise
  // What the projector shows, and the one statement of the gamma its 8-bit patterns are
  // pre-compensated for (PatternScheme::gamma_precompensation; the simulated projector's own
  // gamma is a device property, render.projector.gamma). Its projector size must be the rig's.
  // Unset: the heterodyne-4x3 preset for the rig's projector, not pre-compensated.
  std::optional<phase::PatternScheme> scheme;
  int calibration_images = 15;   // board poses (one image per camera each), >= 0
  CalibrationTarget target;      // the calibration board
  bool truth_maps = true;        // per-view per-camera truth maps (large)
  RenderOptions render;          // image formation (noise seed = seed)
  BoardRenderOptions board;      // board images (noise seed = seed)
  OrbitOptions orbit;            // view poses (views and seed are overridden)
  BoardPoseOptions board_poses;  // board poses (count and seed are overridden)
  // 2: stereo views (views/NNN/left/ and right/). 1: camera + projector views (scan.json
  // "cameras": 1): left/ only (the right camera is not rendered; truth maps of the left only),
  // and calibration/ holds `calibration_images` board pose folders of the camera + projector
  // calibration layout (WriteProjectorCalibrationFolder: board image and both fringe
  // directions per pose).
  int cameras = 2;
  // One camera only: horizontal fringes too (phase = projector row), so that the camera +
  // projector triangulation can use both projector coordinates. The camera folders then hold
  // vertical/ (the scheme) and horizontal/ (horizontal_scheme, scan.json
  // "scheme_horizontal").
  bool both_directions = false;
  // The horizontal scheme; unset: `scheme` with its direction turned horizontal (same periods
  // and steps; names "<name>-horizontal"). Its projector size must be the rig's.
  std::optional<phase::PatternScheme> horizontal_scheme;
  // Exposures of every fringe stack, as factors of render.sensor.exposure, each in (0, 100], at
  // most 8. More than one: every camera (and direction) folder holds exposure folders e0/,
  // e1/, ... (phase::ReadExposureStacks), combined per pixel by the decoder. Exposure 0 is
  // rendered exactly as a single-exposure scan; exposure e > 0 uses the noise streams of view
  // index view + 1000000 * e.
  std::vector<double> exposures = {1.0};

  void Check() const;
};

// Every fringe stack of one view as SimulateScan writes it.
struct ViewStackImages {
  Rigid3d world_from_sensor;
  // images[camera][exposure][scheme]: camera 0 the left, 1 the right (two cameras only);
  // scheme 0 the scheme, 1 the horizontal one (both_directions); each a stack in the scheme's
  // order.
  std::vector<std::vector<std::vector<std::vector<cv::Mat>>>> images;
  std::vector<CameraTruth> truth;  // per camera, of exposure 0 (empty Mats without truth maps)
  std::vector<MarkerObservation> markers;
};

struct ScanSummary {
  int cameras = 2;
  int views = 0;
  int fringe_images = 0;       // per camera
  int calibration_images = 0;  // per camera
  int markers = 0;
  double seconds = 0;
  std::string BriefReport() const;
};
nlohmann::json ToJson(
    const ScanSummary& s);  // the counts and seconds (the Python bindings' summary)

// A simulated scan prepared once (scene, patterns, renderer, view and board poses), rendered
// view by view on demand: the in-memory counterpart of SimulateScan for tests and the demo
// (same images as the files for the same rig and options). Thread safety: const methods may run
// concurrently.
class ScanSimulator {
 public:
  // Throws fringe::Error for bad options, an unknown scene or scheme, or a scheme whose
  // projector size differs from the rig's.
  ScanSimulator(const StereoRig& rig, const ScanOptions& options);
  ~ScanSimulator();
  ScanSimulator(const ScanSimulator&) = delete;
  ScanSimulator& operator=(const ScanSimulator&) = delete;

  const StereoRig& rig() const;
  const ScanOptions& options() const;
  const Scene& scene() const;
  const phase::PatternScheme& scheme() const;  // with gamma_precompensation set
  // The horizontal scheme (both_directions; else the scheme), gamma_precompensation set.
  const phase::PatternScheme& horizontal_scheme() const;
  const std::vector<cv::Mat>& patterns() const;     // projector images, CV_8U
  const std::vector<Rigid3d>& view_poses() const;   // world_from_sensor per view
  const std::vector<Rigid3d>& board_poses() const;  // left_from_board per board image

  ViewImages RenderView(int view) const;  // view in [0, options.views)
  // Every stack of the view (cameras, exposures, directions), as written to the folder.
  ViewStackImages RenderViewStacks(int view) const;
  StereoBoardImages RenderBoard(int index) const;  // index in [0, options.calibration_images)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Renders the scan and writes it to `out_dir` atomically (the folder appears complete or not
// at all; an existing folder is replaced). Throws fringe::Error for bad options or I/O errors.
ScanSummary SimulateScan(const StereoRig& rig, const ScanOptions& options,
                         const std::filesystem::path& out_dir);

// Writes one camera's truth maps into `dir` (created), single-channel so any TIFF reader gets
// them right: depth.tiff (z in the camera frame, mm), normal_x.tiff, normal_y.tiff,
// normal_z.tiff (unit normal in the camera frame, toward the camera), projector_x.tiff,
// projector_y.tiff (continuous projector pixel), all 32-bit float with NaN where undefined;
// valid.png (8-bit, 255 = hit, lit and inside the projector image); object_id.png (16-bit,
// scene object index + 1, 0 = nothing hit). The 3D point of pixel (c, r) is
// depth * (x, y, 1) with (x, y) = camera.Unproject((c, r)).
void WriteCameraTruth(const std::filesystem::path& dir, const CameraTruth& truth);
// Reads them back (float precision, converted to the CameraTruth types); points are rebuilt
// from depth with `camera`.
CameraTruth ReadCameraTruth(const std::filesystem::path& dir, const CameraModel& camera);

}  // namespace fringe::sim
