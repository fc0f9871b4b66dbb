#include "fringe/sim/scan.h"

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
#include "fringe/sim/markers.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/log.h"
#include "fringe/util/random.h"
#include "fringe/util/timer.h"

namespace fringe::sim {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string Index3(int i) {
  std::ostringstream os;
  os << std::setw(3) << std::setfill('0') << i;
  return os.str();
}

json Vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }
json Vec(const Eigen::Vector2d& v) {
  if (!v.allFinite()) return nullptr;
  return json::array({v.x(), v.y()});
}

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
  CheckOption(views >= 0, "ScanOptions", "views", views, "must be >= 0");
  CheckOption(calibration_images >= 0, "ScanOptions", "calibration_images", calibration_images,
              "must be >= 0");
  CheckOption(precompensate_gamma > 0 && precompensate_gamma <= 10, "ScanOptions",
              "precompensate_gamma", precompensate_gamma, "must be in (0, 10]");
  target.Check();
  render.Check();
  board.Check();
}

std::string ScanSummary::BriefReport() const {
  std::ostringstream os;
  os << "simulated scan: " << views << " views x " << fringe_images
     << " fringe images x 2 cameras, " << calibration_images << " calibration images x 2 cameras, "
     << markers << " markers, " << std::fixed << std::setprecision(1) << seconds << " s";
  return os.str();
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
  phase::PatternScheme scheme;
  std::vector<cv::Mat> patterns;
  std::vector<Rigid3d> poses;
  std::unique_ptr<Renderer> renderer;
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
    m.scheme =
        phase::SchemeFromNameOrFile(options.scheme, rig.projector->width, rig.projector->height);
    if (m.scheme.projector_width != rig.projector->width ||
        m.scheme.projector_height != rig.projector->height) {
      throw Error(util::StrCat("simulate: scheme '", options.scheme, "' is for a ",
                               m.scheme.projector_width, "x", m.scheme.projector_height,
                               " projector, the rig's is ", rig.projector->width, "x",
                               rig.projector->height));
    }
    m.patterns = phase::GeneratePatterns(m.scheme, options.precompensate_gamma);
    m.scheme.gamma_precompensation = options.precompensate_gamma;
    RenderOptions ro = options.render;
    ro.sensor.seed = options.seed;
    ro.truth = options.truth_maps;  // markers are observed without the maps
    m.renderer = std::make_unique<Renderer>(m.scene, rig, ro);
    OrbitOptions oo = options.orbit;
    oo.views = options.views;
    oo.seed = options.seed;
    m.poses = OrbitPoses(rig, OrbitTarget(m.scene), oo);
  }
  if (options.calibration_images > 0) {
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
const std::vector<cv::Mat>& ScanSimulator::patterns() const { return impl_->patterns; }
const std::vector<Rigid3d>& ScanSimulator::view_poses() const { return impl_->poses; }
const std::vector<Rigid3d>& ScanSimulator::board_poses() const { return impl_->board_poses; }

ViewImages ScanSimulator::RenderView(int v) const {
  if (v < 0 || v >= static_cast<int>(impl_->poses.size())) {
    throw Error(util::StrCat("ScanSimulator::RenderView: no view ", v));
  }
  return impl_->renderer->RenderView(impl_->poses[v], impl_->patterns, static_cast<uint64_t>(v));
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
    fs::create_directories(tmp / "truth");
    io::WriteRig(tmp / "truth" / "rig.json", rig);
    io::WriteMesh(tmp / "truth" / "scene.ply", scene.CombinedMesh(),
                  {"fringe virtual scanner scene, world frame, mm"});
    json objects = json::array();
    for (const SceneObject& o : scene.objects()) {
      json j = {{"name", o.name},
                {"albedo", o.texture ? json(nullptr) : json(o.albedo)},
                {"triangles", o.mesh.NumTriangles()}};
      if (o.sphere) {
        j["sphere"] = {{"centre_in_world", Vec(o.sphere->centre)},
                       {"radius_mm", o.sphere->radius_mm}};
      }
      objects.push_back(j);
    }
    io::WriteJson(tmp / "truth" / "scene.json", {{"scene", options.scene},
                                                 {"frame", "world, mm, z up"},
                                                 {"mesh", "scene.ply"},
                                                 {"objects", objects}});

    // Fringe views.
    json pose_list = json::array();
    json marker_views = json::array();
    util::Progress progress("simulate views", options.views);
    const std::vector<std::string> names = scheme.ImageNames();
    for (int v = 0; v < options.views; ++v) {
      const ViewImages view = sim.RenderView(v);
      const fs::path vdir = tmp / "views" / Index3(v);
      for (const char* cam : {"left", "right"}) {
        const CameraImages& images = std::string(cam) == "left" ? view.left : view.right;
        fs::create_directories(vdir / cam);
        for (size_t k = 0; k < images.images.size(); ++k) {
          io::WriteImage(vdir / cam / names[k], images.images[k]);
        }
        if (options.truth_maps) {
          WriteCameraTruth(tmp / "truth" / "views" / Index3(v) / cam, images.truth);
        }
      }
      pose_list.push_back({{"view", Index3(v)}, {"world_from_sensor", io::RigidToJson(poses[v])}});
      json obs = json::array();
      for (const MarkerObservation& o : view.markers) {
        obs.push_back({{"id", o.id},
                       {"centre_in_sensor", Vec(o.centre_in_sensor)},
                       {"left_px", Vec(o.left_px)},
                       {"right_px", Vec(o.right_px)},
                       {"visible_left", o.visible_left},
                       {"visible_right", o.visible_right}});
      }
      marker_views.push_back({{"view", Index3(v)}, {"observations", obs}});
      progress.Advance();
    }
    summary.views = options.views;
    summary.fringe_images = static_cast<int>(sim.patterns().size());
    if (options.views > 0) phase::WriteScheme(tmp / "scheme.json", scheme);
    io::WriteJson(tmp / "truth" / "poses.json",
                  {{"frame", "world_from_sensor (sensor = left camera), mm"},
                   {"turntable", options.orbit.turntable},
                   {"views", pose_list}});
    json markers = json::array();
    for (const Marker& m : scene.markers()) {
      markers.push_back({{"id", m.id},
                         {"centre_in_world", Vec(m.centre_in_world)},
                         {"normal_in_world", Vec(m.normal_in_world)},
                         {"inner_radius_mm", m.inner_radius_mm},
                         {"outer_radius_mm", m.outer_radius_mm}});
    }
    io::WriteJson(tmp / "truth" / "markers.json",
                  {{"frame", "world, mm"}, {"markers", markers}, {"views", marker_views}});

    // Calibration board images.
    if (!board_poses.empty()) {
      fs::create_directories(tmp / "calibration" / "left");
      fs::create_directories(tmp / "calibration" / "right");
      io::WriteJson(tmp / "calibration" / "target.json", io::TargetToJson(options.target));
      json images = json::array();
      util::Progress board_progress("simulate calibration images",
                                    static_cast<int>(board_poses.size()));
      for (size_t i = 0; i < board_poses.size(); ++i) {
        const StereoBoardImages b = sim.RenderBoard(static_cast<int>(i));
        const std::string name = Index3(static_cast<int>(i)) + ".png";
        io::WriteImage(tmp / "calibration" / "left" / name, b.left.image);
        io::WriteImage(tmp / "calibration" / "right" / name, b.right.image);
        auto camera_json = [](const BoardImage& img) {
          json centres = json::array();
          for (const auto& c : img.centres_px) centres.push_back(Vec(c));
          return json{{"centres_px", centres}, {"visible", img.visible}};
        };
        images.push_back({{"image", name},
                          {"left_from_board", io::RigidToJson(board_poses[i])},
                          {"left", camera_json(b.left)},
                          {"right", camera_json(b.right)}});
        board_progress.Advance();
      }
      io::WriteJson(tmp / "truth" / "calibration.json",
                    {{"target", io::TargetToJson(options.target)},
                     {"features", "row-major, index = row * cols + col"},
                     {"images", images}});
    }
    summary.calibration_images = static_cast<int>(board_poses.size());

    const CameraModel& cam = rig.left;
    io::WriteJson(
        tmp / "scan.json",
        {{"format", "fringe-scan"},
         {"version", 1},
         {"generator", "fringe simulate"},
         {"scene", options.scene},
         {"seed", options.seed},
         {"views", options.views},
         {"image_width", cam.width},
         {"image_height", cam.height},
         {"bit_depth", options.render.sensor.bit_depth},
         {"scheme", options.views > 0 ? json("scheme.json") : json(nullptr)},
         {"calibration_images", summary.calibration_images},
         {"calibration_target",
          summary.calibration_images > 0 ? json("calibration/target.json") : json(nullptr)},
         {"truth", "truth"}});
  });
  summary.seconds = timer.ElapsedSeconds();
  return summary;
}

}  // namespace fringe::sim
