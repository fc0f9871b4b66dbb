// The scan folder (docs/scan-folder.md): the one place that knows its layout, reads and checks
// its manifest, discovers its views and reads its scheme, calibration images and truth. The
// simulator writes scan folders through ScanLayout and the writers here (sim/scan.cc); the
// demo, `fringe reconstruct`, `fringe info` and the whole-scanner command read them through
// ScanFolder.
//
//   DIR/scan.json                  manifest (ScanManifest)
//   DIR/scheme.json                pattern scheme manifest
//   DIR/views/NNN/{left,right}/    fringe image stacks, names from the scheme (left/ only in a
//                                  camera + projector scan, scan.json "cameras": 1)
//   DIR/calibration/target.json    calibration board
//   DIR/calibration/{left,right}/  board images, KKK.png (two cameras), or
//   DIR/calibration/KKK/           one board pose of the camera + projector calibration layout
//                                  (calib/projector_folder.h; one camera)
//   DIR/truth/                     simulated scans only (truth.h, sim::ReadCameraTruth)
//
// Errors: every problem throws fringe::Error naming the file or folder and what was expected.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fringe/geometry/calibration_target.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/geometry/triangle_mesh.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/scan/truth.h"

namespace fringe::scan {

enum class Camera { kLeft, kRight };
// "left" / "right": the camera's folder name.
const char* CameraName(Camera camera);

// Three-digit index names of views and board images: 7 -> "007".
std::string IndexName(int index);

// Where everything lives in a scan folder rooted at `root`; nothing is read or checked.
struct ScanLayout {
  std::filesystem::path root;
  // The view sub-folders of the cameras: fringe's left/ right/, or another tool's L/ R/ or
  // cam0/ cam1/ (ScanManifest::camera_folders).
  std::string left_folder = "left", right_folder = "right";

  std::filesystem::path Manifest() const { return root / "scan.json"; }
  // The folder's own rig, when it has one (else it is calibrated from CalibrationDir()).
  std::filesystem::path Rig() const { return root / "rig.json"; }
  std::filesystem::path Scheme() const { return root / "scheme.json"; }
  // The horizontal-fringe scheme of a one-camera scan with both directions.
  std::filesystem::path HorizontalScheme() const { return root / "scheme_horizontal.json"; }
  std::filesystem::path ViewsDir() const { return root / "views"; }
  std::filesystem::path ViewDir(const std::string& view) const { return ViewsDir() / view; }
  std::filesystem::path CameraDir(const std::string& view, Camera camera) const {
    return ViewDir(view) / (camera == Camera::kLeft ? left_folder : right_folder);
  }
  // One camera, both fringe directions: the stack of one direction, CameraDir / "vertical" or
  // "horizontal" (phase::DirectionName).
  std::filesystem::path DirectionDir(const std::string& view, Camera camera,
                                     phase::FringeDirection direction) const {
    return CameraDir(view, camera) / phase::DirectionName(direction);
  }
  std::filesystem::path CalibrationDir() const { return root / "calibration"; }
  std::filesystem::path CalibrationDir(Camera camera) const {
    return CalibrationDir() / (camera == Camera::kLeft ? left_folder : right_folder);
  }
  std::filesystem::path Target() const { return CalibrationDir() / "target.json"; }
  std::filesystem::path TruthDir() const { return root / "truth"; }
  std::filesystem::path TruthRig() const { return TruthDir() / "rig.json"; }
  std::filesystem::path TruthPoses() const { return TruthDir() / "poses.json"; }
  std::filesystem::path TruthMarkers() const { return TruthDir() / "markers.json"; }
  std::filesystem::path TruthScene() const { return TruthDir() / "scene.json"; }
  std::filesystem::path TruthMesh() const { return TruthDir() / "scene.ply"; }
  std::filesystem::path TruthCalibration() const { return TruthDir() / "calibration.json"; }
  // Per-pixel truth maps of one camera in one view (sim::WriteCameraTruth / ReadCameraTruth).
  std::filesystem::path TruthMaps(const std::string& view, Camera camera) const {
    return TruthDir() / "views" / view / CameraName(camera);
  }
};

// scan.json. Relative paths are empty when the scan has no such part.
struct ScanManifest {
  static constexpr int kVersion = 1;
  std::string generator;  // who wrote the folder, e.g. "fringe simulate"
  std::string scene;      // scene name of a simulated scan, else empty
  uint64_t seed = 0;      // simulation seed
  int views = 0;          // number of view folders views/NNN
  int image_width = 0;    // camera image size, px
  int image_height = 0;
  int bit_depth = 8;  // 8, or 10 / 12 / 14 / 16 (stored in 16-bit PNG)
  // 2: stereo views (left/ and right/); 1: camera + projector views (left/ only), the projector
  // calibrated as an inverse camera. JSON key "cameras", optional (default 2).
  int cameras = 2;
  std::string scheme;  // "scheme.json" when there are views
  // One camera only: the horizontal-fringe scheme ("scheme_horizontal.json") when every view
  // holds both directions, left/vertical/ (scheme) and left/horizontal/ (this one); empty:
  // one direction, the stack in left/. JSON key "scheme_horizontal", optional.
  std::string scheme_horizontal;
  // The cameras' folders in every view when not left/ right/: {"L", "R"} or {"cam0", "cam1"}
  // (one camera: {"L"} or {"cam0"}). JSON key "camera_folders", optional.
  std::vector<std::string> camera_folders;
  int calibration_images = 0;      // board images per camera (one camera: board pose folders)
  std::string calibration_target;  // "calibration/target.json" when there are board images
  std::string truth;               // "truth" for simulated scans
};
nlohmann::json ManifestToJson(const ScanManifest& manifest);
// Throws fringe::Error naming `context` for a missing / mistyped field, another format or a
// newer version, or inconsistent values (negative counts, a bit depth other than 8 or 12).
ScanManifest ManifestFromJson(const nlohmann::json& j, const std::string& context);
void WriteManifest(const std::filesystem::path& path, const ScanManifest& manifest);

// The camera folder names a view may use, fringe's first: {left, right}, {L, R}, {cam0, cam1}.
const std::vector<std::pair<std::string, std::string>>& CameraFolderNames();

// A folder of views written by another tool (views/NNN/{left,right | L,R | cam0,cam1}/ +
// scheme.json) has no scan.json: its manifest is inferred from the folder: the views, the camera
// folders (two, or one for camera + projector), the image size and bit depth of the first image
// (16-bit images are taken as 16-bit: write bit_depth 12 for 12-bit sensors), scheme.json
// (required with views; scheme_horizontal.json with one camera), calibration/target.json with
// its board images or pose folders. `notes` say what was inferred and from where. Throws
// fringe::Error naming the folder when the manifest cannot be inferred.
struct InferredManifest {
  ScanManifest manifest;
  std::vector<std::string> notes;
};
InferredManifest InferManifest(const std::filesystem::path& root);

// `fringe info ROOT --init`, `fringe scan ROOT --write-manifest`: infers ROOT's manifest, checks
// the folder against it (ScanFolder::Open) and writes ROOT/scan.json (atomically). Throws
// fringe::Error naming ROOT when it already has a scan.json (never overwritten) or the manifest
// cannot be inferred. Returns what was inferred.
InferredManifest WriteInferredManifest(const std::filesystem::path& root);

// A scan folder opened for reading and checked against its manifest.
class ScanFolder {
 public:
  // Reads ROOT/scan.json and checks the folder against it: the views under views/ are exactly
  // 000 .. views-1, each with left/ and right/ (one camera: left/ and no right/); the scheme,
  // target and truth folder it names exist; calibration/left and right each hold
  // `calibration_images` images with the same names (one camera: calibration/ holds
  // `calibration_images` board pose folders). Throws fringe::Error naming the first file or
  // folder that disagrees.
  // Without scan.json the manifest is inferred (InferManifest; inferred() is true and
  // inferred_notes() say what was inferred; the folder is not written to).
  static ScanFolder Open(const std::filesystem::path& root);
  bool inferred() const { return !inferred_notes_.empty(); }
  const std::vector<std::string>& inferred_notes() const { return inferred_notes_; }
  // True when `dir` has a scan.json (a scan folder, maybe invalid).
  static bool IsScanFolder(const std::filesystem::path& dir);
  // The root of the scan folder that `view_dir` (ROOT/views/NNN) belongs to, if it is one.
  static std::optional<std::filesystem::path> RootOfView(const std::filesystem::path& view_dir);

  const ScanLayout& layout() const { return layout_; }
  const std::filesystem::path& root() const { return layout_.root; }
  const ScanManifest& manifest() const { return manifest_; }

  // View names, sorted ("000", "001", ...).
  const std::vector<std::string>& views() const { return views_; }
  bool has_views() const { return !views_.empty(); }
  // Two cameras (stereo views) or one (camera + projector views, left/ only).
  bool stereo() const { return manifest_.cameras == 2; }
  // The pattern scheme (scheme.json); throws when the scan has none.
  phase::PatternScheme ReadScheme() const;
  // One camera with both fringe directions (scan.json "scheme_horizontal").
  bool both_directions() const { return !manifest_.scheme_horizontal.empty(); }
  // The schemes of every view's stacks: {scheme}, or {vertical, horizontal} with both
  // directions (throws unless the first has vertical and the second horizontal fringes).
  std::vector<phase::PatternScheme> ReadSchemes() const;
  // The folder of scheme k's stack (k indexes ReadSchemes()): the camera folder, or its
  // vertical/ (k = 0) or horizontal/ (k = 1) with both directions.
  std::filesystem::path StackDir(const std::string& view, Camera camera, size_t k) const;
  // Every scheme's stacks at every exposure: [scheme][exposure] (ReadExposureStacks of each
  // StackDir); all schemes must have the same number of exposures (an error naming the folder).
  std::vector<std::vector<std::vector<cv::Mat>>> ReadViewStacks(
      const std::string& view, Camera camera,
      const std::vector<phase::PatternScheme>& schemes) const;
  // One camera's fringe images of a view in the scheme's order (phase::ReadStack checks them);
  // an error when the camera folder holds several exposures.
  std::vector<cv::Mat> ReadStack(const std::string& view, Camera camera,
                                 const phase::PatternScheme& scheme) const;
  // The same at one or several exposures (exposure folders e0/, e1/, ... in the camera folder;
  // phase::ReadExposureStacks), every image of the manifest's size.
  std::vector<std::vector<cv::Mat>> ReadExposureStacks(const std::string& view, Camera camera,
                                                       const phase::PatternScheme& scheme) const;

  bool has_calibration() const { return manifest_.calibration_images > 0; }
  // Board image file names (same in left/ and right/), sorted; one camera: the board pose
  // folder names.
  const std::vector<std::string>& calibration_images() const { return calibration_images_; }
  CalibrationTarget ReadTarget() const;

  bool has_truth() const { return !manifest_.truth.empty(); }
  StereoRig ReadTruthRig() const;
  TruthPoses ReadTruthPoses() const;
  TruthMarkers ReadTruthMarkers() const;
  TruthScene ReadTruthScene() const;
  TriangleMesh ReadTruthMesh() const;  // world frame

 private:
  void RequireTruth(const std::filesystem::path& file) const;

  ScanLayout layout_;
  ScanManifest manifest_;
  std::vector<std::string> views_;
  std::vector<std::string> calibration_images_;
  std::vector<std::string> inferred_notes_;
};

}  // namespace fringe::scan
