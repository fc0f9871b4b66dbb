#include "fringe/sim/scan.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/mesh_io.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/stack_io.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/sim/markers.h"
#include "fringe/sim/projector_board.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/log.h"
#include "fringe/util/random.h"
#include "fringe/util/timer.h"

namespace fringe::sim {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Markers on the base plate of scenes that have one, so registration has something to use.
void AddPlateMarkers(Scene* scene, uint64_t seed) {
  if (!scene->FindObject("base_plate")) return;
  MarkerOptions mo;
  mo.count = 20;
  mo.seed = seed;
  mo.objects = {"base_plate"};
  PlaceMarkers(scene, mo);
}

Eigen::Vector3d OrbitTarget(const Scene& scene) {
  Eigen::Vector3d lo, hi;
  bool any = false;
  for (const SceneObject& o : scene.objects()) {
    if (o.name == "base_plate") continue;
    Eigen::Vector3d a, b;
    o.mesh.Bounds(&a, &b);
    lo = any ? lo.cwiseMin(a) : a;
    hi = any ? hi.cwiseMax(b) : b;
    any = true;
  }
  if (!any) scene.Bounds(&lo, &hi);
  return 0.5 * (lo + hi);
}

cv::Mat ToFloat(const cv::Mat& m) {
  cv::Mat f;
  m.convertTo(f, CV_32F);
  return f;
}

}  // namespace

std::vector<std::string> SceneNames() {
  return {"demo", "board", "sphere", "ballbar", "plane", "plate", "vdi"};
}

Scene MakeBoardScene(const CalibrationTarget& target) {
  target.Check();
  Eigen::Vector2d lo, hi;
  target.Extent(&lo, &hi);
  const Eigen::Vector2d mid = 0.5 * (lo + hi);
  SceneObject board;
  board.name = "board";
  // The printed side faces world +z: board frame = world rotated 180 degrees about x.
  board.texture = [target, mid](const Eigen::Vector3d& p) {
    BoardRenderOptions o;
    o.background_albedo = 0.5;
    return BoardAlbedo(target, p.x() + mid.x(), -p.y() + mid.y(), o);
  };
  board.mesh =
      MakeRectangleMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                        hi.x() - lo.x() + 20, hi.y() - lo.y() + 20);
  Scene scene;
  scene.AddObject(std::move(board));
  return scene;
}

Scene MakeSceneByName(const std::string& name, uint64_t seed) {
  if (name.rfind("mesh:", 0) == 0) return MakeMeshScene(name.substr(5));
  Scene scene;
  if (name == "demo") {
    DemoPartOptions o;
    o.seed = seed;
    return MakeDemoPart(o);
  } else if (name == "board") {
    return MakeBoardScene();
  } else if (name == "sphere") {
    scene = MakeSphereScene();
  } else if (name == "ballbar") {
    scene = MakeBallBarScene();
  } else if (name == "plane") {
    return MakePlaneScene();
  } else if (name == "plate") {
    return MakePlateScene();
  } else if (name == "vdi") {
    scene = MakeVdiScene();
  } else {
    throw Error(util::StrCat("unknown scene '", name,
                             "' (expected demo, board, sphere, ballbar, plane, plate, vdi or "
                             "mesh:FILE)"));
  }
  AddPlateMarkers(&scene, seed);
  return scene;
}

void ScanOptions::Check() const {
  using util::CheckOption;
  // A bound, not a physical limit: each view is ~25 MB of images at full size, and a typo such
  // as 100000 would otherwise run for days and fill the disk.
  CheckOption(views >= 0 && views <= 1000, "ScanOptions", "views", views, "must be in [0, 1000]");
  CheckOption(calibration_images >= 0 && calibration_images <= 1000, "ScanOptions",
              "calibration_images", calibration_images, "must be in [0, 1000]");
  if (scheme) {
    scheme->Check();
    CheckOption(scheme->gamma_precompensation > 0 && scheme->gamma_precompensation <= 10,
                "ScanOptions", "scheme.gamma_precompensation", scheme->gamma_precompensation,
                "must be in (0, 10]");
  }
  CheckOption(cameras == 1 || cameras == 2, "ScanOptions", "cameras", cameras, "must be 1 or 2");
  CheckOption(!both_directions || cameras == 1, "ScanOptions", "both_directions", both_directions,
              "needs cameras = 1 (stereo matching uses vertical fringes only)");
  if (horizontal_scheme) {
    horizontal_scheme->Check();
    CheckOption(horizontal_scheme->direction == phase::FringeDirection::kHorizontal, "ScanOptions",
                "horizontal_scheme.direction", phase::DirectionName(horizontal_scheme->direction),
                "must be horizontal");
  }
  CheckOption(!exposures.empty() && exposures.size() <= 8, "ScanOptions", "exposures",
              exposures.size(), "must hold 1 to 8 exposure factors");
  for (double e : exposures) {
    CheckOption(e > 0 && e <= 100, "ScanOptions", "exposures", e, "must be in (0, 100]");
  }
  target.Check();
  render.Check();
  board.Check();
}

std::string ScanSummary::BriefReport() const {
  std::ostringstream os;
  const char* per = cameras == 2 ? " x 2 cameras" : " (one camera + projector)";
  os << "simulated scan: " << views << " views x " << fringe_images << " fringe images" << per
     << ", " << calibration_images
     << (cameras == 2 ? " calibration images x 2 cameras, " : " board pose folders, ") << markers
     << " markers, " << std::fixed << std::setprecision(1) << seconds << " s";
  return os.str();
}

nlohmann::json ToJson(const ScanSummary& s) {
  return {{"cameras", s.cameras},
          {"views", s.views},
          {"fringe_images", s.fringe_images},
          {"calibration_images", s.calibration_images},
          {"markers", s.markers},
          {"seconds", s.seconds},
          {"report", s.BriefReport()}};
}

void WriteCameraTruth(const fs::path& dir, const CameraTruth& truth) {
  fs::create_directories(dir);
  io::WriteImage(dir / "depth.tiff", ToFloat(truth.depth));
  cv::Mat n[3], uv[2];
  cv::split(truth.normals, n);
  cv::split(truth.projector, uv);
  io::WriteImage(dir / "normal_x.tiff", ToFloat(n[0]));
  io::WriteImage(dir / "normal_y.tiff", ToFloat(n[1]));
  io::WriteImage(dir / "normal_z.tiff", ToFloat(n[2]));
  io::WriteImage(dir / "projector_x.tiff", ToFloat(uv[0]));
  io::WriteImage(dir / "projector_y.tiff", ToFloat(uv[1]));
  io::WriteImage(dir / "valid.png", truth.valid);
  cv::Mat ids;
  truth.object_id.convertTo(ids, CV_16U, 1.0, 1.0);
  io::WriteImage(dir / "object_id.png", ids);
}

CameraTruth ReadCameraTruth(const fs::path& dir, const CameraModel& camera) {
  const cv::Size size(camera.width, camera.height);
  auto read = [&](const char* name) {
    cv::Mat d;
    io::ReadFloatImage(dir / name, size).convertTo(d, CV_64F);
    return d;
  };
  CameraTruth t;
  t.depth = read("depth.tiff");
  cv::merge(
      std::vector<cv::Mat>{read("normal_x.tiff"), read("normal_y.tiff"), read("normal_z.tiff")},
      t.normals);
  cv::merge(std::vector<cv::Mat>{read("projector_x.tiff"), read("projector_y.tiff")}, t.projector);
  t.valid = io::ReadGrayImage(dir / "valid.png", size);
  io::ReadGrayImage(dir / "object_id.png", size).convertTo(t.object_id, CV_32S, 1.0, -1.0);
  t.points.create(size, CV_64FC3);
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      const double z = t.depth.at<double>(r, c);
      const Eigen::Vector2d xy = camera.Unproject(Eigen::Vector2d(c, r));
      t.points.at<cv::Vec3d>(r, c) = cv::Vec3d(z * xy.x(), z * xy.y(), z);
    }
  }
  return t;
}

struct ScanSimulator::Impl {
  StereoRig rig;
  ScanOptions options;
  Scene scene;
  phase::PatternScheme scheme, horizontal_scheme;
  std::vector<cv::Mat> patterns, horizontal_patterns;
  std::vector<Rigid3d> poses;
  std::unique_ptr<Renderer> renderer;
  // Exposures e >= 1 (the sensor's exposure scaled), without truth maps.
  std::vector<std::unique_ptr<Renderer>> exposure_renderers;
  std::vector<Rigid3d> board_poses;
  BoardRenderOptions board_options;
};

ScanSimulator::ScanSimulator(const StereoRig& rig, const ScanOptions& options)
    : impl_(std::make_unique<Impl>()) {
  options.Check();
  rig.Check();
  Impl& m = *impl_;
  m.rig = rig;
  m.options = options;
  m.scene = MakeSceneByName(options.scene, options.seed);
  if (options.views > 0) {
    if (!rig.projector) throw Error("simulate: the rig has no projector (projector_from_left)");
    m.scheme = options.scheme ? *options.scheme
                              : phase::MakeScheme("heterodyne-4x3", rig.projector->width,
                                                  rig.projector->height);
    if (m.scheme.projector_width != rig.projector->width ||
        m.scheme.projector_height != rig.projector->height) {
      throw Error(util::StrCat("simulate: scheme '", m.scheme.name, "' is for a ",
                               m.scheme.projector_width, "x", m.scheme.projector_height,
                               " projector, the rig's is ", rig.projector->width, "x",
                               rig.projector->height));
    }
    m.patterns = phase::GeneratePatterns(m.scheme, m.scheme.gamma_precompensation);
    m.horizontal_scheme = m.scheme;
    if (options.both_directions) {
      if (options.horizontal_scheme) {
        m.horizontal_scheme = *options.horizontal_scheme;
      } else {
        m.horizontal_scheme.direction = phase::FringeDirection::kHorizontal;
        m.horizontal_scheme.name = m.scheme.name + "-horizontal";
      }
      m.horizontal_scheme.Check();
      if (m.horizontal_scheme.projector_width != rig.projector->width ||
          m.horizontal_scheme.projector_height != rig.projector->height) {
        throw Error(util::StrCat("simulate: horizontal scheme '", m.horizontal_scheme.name,
                                 "' is for a ", m.horizontal_scheme.projector_width, "x",
                                 m.horizontal_scheme.projector_height, " projector, the rig's is ",
                                 rig.projector->width, "x", rig.projector->height));
      }
      m.horizontal_patterns =
          phase::GeneratePatterns(m.horizontal_scheme, m.horizontal_scheme.gamma_precompensation);
    }
    RenderOptions ro = options.render;
    ro.sensor.seed = options.seed;
    ro.truth = options.truth_maps;  // markers are observed without the maps
    ro.sensor.exposure = options.render.sensor.exposure * options.exposures.front();
    m.renderer = std::make_unique<Renderer>(m.scene, rig, ro);
    for (size_t e = 1; e < options.exposures.size(); ++e) {
      RenderOptions re = ro;
      re.truth = false;
      re.sensor.exposure = options.render.sensor.exposure * options.exposures[e];
      m.exposure_renderers.push_back(std::make_unique<Renderer>(m.scene, rig, re));
    }
    OrbitOptions oo = options.orbit;
    oo.views = options.views;
    oo.seed = options.seed;
    m.poses = OrbitPoses(rig, OrbitTarget(m.scene), oo);
  }
  // One camera: the board pose folders are rendered by WriteProjectorCalibrationFolder.
  if (options.calibration_images > 0 && options.cameras == 2) {
    BoardPoseOptions bo = options.board_poses;
    bo.count = options.calibration_images;
    bo.seed = util::MixSeed(options.seed, 0xB0A4D);
    m.board_poses = GenerateBoardPoses(rig, options.target, bo);
  }
  m.board_options = options.board;
  m.board_options.sensor.seed = options.seed;
}

ScanSimulator::~ScanSimulator() = default;

const StereoRig& ScanSimulator::rig() const { return impl_->rig; }
const ScanOptions& ScanSimulator::options() const { return impl_->options; }
const Scene& ScanSimulator::scene() const { return impl_->scene; }
const phase::PatternScheme& ScanSimulator::scheme() const { return impl_->scheme; }
const phase::PatternScheme& ScanSimulator::horizontal_scheme() const {
  return impl_->horizontal_scheme;
}
const std::vector<cv::Mat>& ScanSimulator::patterns() const { return impl_->patterns; }
const std::vector<Rigid3d>& ScanSimulator::view_poses() const { return impl_->poses; }
const std::vector<Rigid3d>& ScanSimulator::board_poses() const { return impl_->board_poses; }

ViewImages ScanSimulator::RenderView(int v) const {
  if (v < 0 || v >= static_cast<int>(impl_->poses.size())) {
    throw Error(util::StrCat("ScanSimulator::RenderView: no view ", v));
  }
  return impl_->renderer->RenderView(impl_->poses[v], impl_->patterns, static_cast<uint64_t>(v));
}

ViewStackImages ScanSimulator::RenderViewStacks(int v) const {
  if (v < 0 || v >= static_cast<int>(impl_->poses.size())) {
    throw Error(util::StrCat("ScanSimulator::RenderViewStacks: no view ", v));
  }
  const Impl& m = *impl_;
  const Rigid3d& world_from_sensor = m.poses[static_cast<size_t>(v)];
  const Rigid3d world_from_projector = world_from_sensor * m.rig.projector_from_left.Inverse();
  const int cameras = m.options.cameras;
  const bool both = m.options.both_directions;
  // Both directions in one pass: the noise of pattern k is its own stream (renderer.h), so the
  // vertical images are those of a one-direction scan.
  std::vector<cv::Mat> patterns = m.patterns;
  if (both)
    patterns.insert(patterns.end(), m.horizontal_patterns.begin(), m.horizontal_patterns.end());
  ViewStackImages out;
  out.world_from_sensor = world_from_sensor;
  out.images.resize(static_cast<size_t>(cameras));
  out.truth.resize(static_cast<size_t>(cameras));
  for (size_t e = 0; e < m.options.exposures.size(); ++e) {
    const Renderer& renderer = e == 0 ? *m.renderer : *m.exposure_renderers[e - 1];
    const uint64_t stream = static_cast<uint64_t>(v) + 1000000 * static_cast<uint64_t>(e);
    for (int c = 0; c < cameras; ++c) {
      CameraImages images =
          c == 0 ? renderer.RenderCamera(m.rig.left, world_from_sensor, world_from_projector,
                                         patterns, stream, 0)
                 : renderer.RenderCamera(m.rig.right,
                                         world_from_sensor * m.rig.right_from_left.Inverse(),
                                         world_from_projector, patterns, stream, 1);
      std::vector<std::vector<cv::Mat>> stacks;
      const auto split = images.images.begin() + static_cast<std::ptrdiff_t>(m.patterns.size());
      stacks.emplace_back(images.images.begin(), split);
      if (both) stacks.emplace_back(split, images.images.end());
      out.images[static_cast<size_t>(c)].push_back(std::move(stacks));
      if (e == 0) out.truth[static_cast<size_t>(c)] = std::move(images.truth);
    }
  }
  out.markers = m.renderer->ObserveMarkers(world_from_sensor);
  return out;
}

StereoBoardImages ScanSimulator::RenderBoard(int i) const {
  if (i < 0 || i >= static_cast<int>(impl_->board_poses.size())) {
    throw Error(util::StrCat("ScanSimulator::RenderBoard: no board pose ", i));
  }
  return RenderStereoBoard(impl_->rig, impl_->options.target, impl_->board_poses[i],
                           impl_->board_options, static_cast<uint64_t>(i));
}

ScanSummary SimulateScan(const StereoRig& rig, const ScanOptions& options,
                         const fs::path& out_dir) {
  const util::Timer timer;
  const ScanSimulator sim(rig, options);
  const Scene& scene = sim.scene();
  const phase::PatternScheme& scheme = sim.scheme();
  const std::vector<Rigid3d>& poses = sim.view_poses();
  const std::vector<Rigid3d>& board_poses = sim.board_poses();
  ScanSummary summary;
  summary.markers = static_cast<int>(scene.markers().size());

  util::WriteFolderAtomically(out_dir, [&](const fs::path& tmp) {
    const scan::ScanLayout layout{tmp};
    fs::create_directories(layout.TruthDir());
    io::WriteRig(layout.TruthRig(), rig);
    io::WriteMesh(layout.TruthMesh(), scene.CombinedMesh(),
                  {"fringe virtual scanner scene, world frame, mm"});
    scan::TruthScene truth_scene;
    truth_scene.scene = options.scene;
    truth_scene.mesh = layout.TruthMesh().filename().string();
    for (const SceneObject& o : scene.objects()) {
      scan::TruthObject t;
      t.name = o.name;
      if (!o.texture) t.albedo = o.albedo;
      t.triangles = o.mesh.NumTriangles();
      if (o.sphere) t.sphere = scan::TruthSphere{o.sphere->centre, o.sphere->radius_mm};
      truth_scene.objects.push_back(t);
    }
    scan::WriteTruthScene(layout.TruthScene(), truth_scene);

    // Fringe views.
    scan::TruthPoses truth_poses;
    truth_poses.turntable = options.orbit.turntable;
    scan::TruthMarkers truth_markers;
    truth_markers.markers = scene.markers();
    util::Progress progress("simulate views", options.views);
    const std::vector<std::vector<std::string>> names = {scheme.ImageNames(),
                                                         sim.horizontal_scheme().ImageNames()};
    const bool several_exposures = options.exposures.size() > 1;
    for (int v = 0; v < options.views; ++v) {
      const ViewStackImages view = sim.RenderViewStacks(v);
      const std::string view_name = scan::IndexName(v);
      for (size_t c = 0; c < view.images.size(); ++c) {
        const scan::Camera cam = c == 0 ? scan::Camera::kLeft : scan::Camera::kRight;
        for (size_t e = 0; e < view.images[c].size(); ++e) {
          for (size_t k = 0; k < view.images[c][e].size(); ++k) {
            // <camera>/[vertical|horizontal/][e<e>/]PP.png (docs/scan-folder.md)
            fs::path dir = options.both_directions
                               ? layout.DirectionDir(view_name, cam,
                                                     k == 0 ? phase::FringeDirection::kVertical
                                                            : phase::FringeDirection::kHorizontal)
                               : layout.CameraDir(view_name, cam);
            if (several_exposures) dir = phase::ExposureDir(dir, static_cast<int>(e));
            fs::create_directories(dir);
            const std::vector<cv::Mat>& images = view.images[c][e][k];
            for (size_t i = 0; i < images.size(); ++i) io::WriteImage(dir / names[k][i], images[i]);
          }
        }
        if (options.truth_maps) WriteCameraTruth(layout.TruthMaps(view_name, cam), view.truth[c]);
      }
      truth_poses.views.push_back({view_name, poses[v]});
      truth_markers.views.push_back({view_name, view.markers});
      progress.Advance();
    }
    summary.views = options.views;
    summary.fringe_images = static_cast<int>(sim.patterns().size());
    if (options.views > 0) phase::WriteScheme(layout.Scheme(), scheme);
    if (options.views > 0 && options.both_directions) {
      phase::WriteScheme(layout.HorizontalScheme(), sim.horizontal_scheme());
    }
    scan::WriteTruthPoses(layout.TruthPoses(), truth_poses);
    scan::WriteTruthMarkers(layout.TruthMarkers(), truth_markers);

    // Calibration: one camera, board pose folders with both fringe directions (the camera +
    // projector calibration layout) and their poses as the truth.
    if (options.cameras == 1 && options.calibration_images > 0) {
      ProjectorCalibrationFolderOptions po;
      po.poses = options.board_poses;
      po.poses.count = options.calibration_images;
      po.poses.seed = util::MixSeed(options.seed, 0xB0A4D);
      po.fringes.board = options.board;
      po.fringes.board.sensor.seed = options.seed;
      po.fringes.supersampling = std::min(8, options.render.sensor.supersampling);
      const std::vector<Rigid3d> poses_of_boards =
          WriteProjectorCalibrationFolder(rig, options.target, layout.CalibrationDir(), po);
      json images = json::array();
      for (size_t i = 0; i < poses_of_boards.size(); ++i) {
        images.push_back({{"image", scan::IndexName(static_cast<int>(i))},
                          {"left_from_board", io::RigidToJson(poses_of_boards[i])}});
      }
      io::WriteJson(layout.TruthCalibration(), {{"target", io::TargetToJson(options.target)},
                                                {"features", "row-major, index = row * cols + col"},
                                                {"images", images}});
      summary.calibration_images = static_cast<int>(poses_of_boards.size());
    }
    // Calibration board images.
    if (!board_poses.empty()) {
      fs::create_directories(layout.CalibrationDir(scan::Camera::kLeft));
      fs::create_directories(layout.CalibrationDir(scan::Camera::kRight));
      io::WriteJson(layout.Target(), io::TargetToJson(options.target));
      json images = json::array();
      util::Progress board_progress("simulate calibration images",
                                    static_cast<int>(board_poses.size()));
      for (size_t i = 0; i < board_poses.size(); ++i) {
        const StereoBoardImages b = sim.RenderBoard(static_cast<int>(i));
        const std::string name = scan::IndexName(static_cast<int>(i)) + ".png";
        io::WriteImage(layout.CalibrationDir(scan::Camera::kLeft) / name, b.left.image);
        io::WriteImage(layout.CalibrationDir(scan::Camera::kRight) / name, b.right.image);
        auto camera_json = [](const BoardImage& img) {
          json centres = json::array();
          for (const auto& c : img.centres_px) {
            centres.push_back(c.allFinite() ? json::array({c.x(), c.y()}) : json(nullptr));
          }
          return json{{"centres_px", centres}, {"visible", img.visible}};
        };
        images.push_back({{"image", name},
                          {"left_from_board", io::RigidToJson(board_poses[i])},
                          {"left", camera_json(b.left)},
                          {"right", camera_json(b.right)}});
        board_progress.Advance();
      }
      io::WriteJson(layout.TruthCalibration(), {{"target", io::TargetToJson(options.target)},
                                                {"features", "row-major, index = row * cols + col"},
                                                {"images", images}});
    }
    if (options.cameras == 2) summary.calibration_images = static_cast<int>(board_poses.size());
    summary.cameras = options.cameras;

    scan::ScanManifest manifest;
    manifest.generator = "fringe simulate";
    manifest.scene = options.scene;
    manifest.seed = options.seed;
    manifest.views = options.views;
    manifest.image_width = rig.left.width;
    manifest.image_height = rig.left.height;
    manifest.bit_depth = options.render.sensor.bit_depth;
    manifest.cameras = options.cameras;
    if (options.views > 0) manifest.scheme = layout.Scheme().filename().string();
    if (options.views > 0 && options.both_directions) {
      manifest.scheme_horizontal = layout.HorizontalScheme().filename().string();
    }
    manifest.calibration_images = summary.calibration_images;
    if (summary.calibration_images > 0) {
      manifest.calibration_target = layout.Target().lexically_relative(tmp).generic_string();
    }
    manifest.truth = layout.TruthDir().filename().string();
    scan::WriteManifest(layout.Manifest(), manifest);
  });
  summary.seconds = timer.ElapsedSeconds();
  return summary;
}

}  // namespace fringe::sim
