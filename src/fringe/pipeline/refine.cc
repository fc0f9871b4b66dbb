#include "fringe/pipeline/refine.h"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "fringe/eval/artefact.h"
#include "fringe/eval/vdi2634.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/opencv_calibration.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/format.h"
#include "fringe/util/log.h"
#include "fringe/util/timer.h"

namespace fringe::pipeline {
namespace {

namespace fs = std::filesystem;
using util::StrCat;

// The right phase must be valid around the point's projection (the bicubic interpolation reads
// 4 x 4 samples, and the projection moves by the rig's correction): a window of +-kMargin px.
constexpr int kMargin = 3;

bool PhaseValidAround(const cv::Mat& phase, const Eigen::Vector2d& px) {
  const int c = static_cast<int>(std::lround(px.x())), r = static_cast<int>(std::lround(px.y()));
  if (c - kMargin < 0 || r - kMargin < 0 || c + kMargin >= phase.cols ||
      r + kMargin >= phase.rows) {
    return false;
  }
  for (int y = r - kMargin; y <= r + kMargin; ++y) {
    const float* row = phase.ptr<float>(y);
    for (int x = c - kMargin; x <= c + kMargin; ++x) {
      if (!std::isfinite(row[x])) return false;
    }
  }
  return true;
}

// MarkSpherePoints' acceptance (pipeline/refine.h).
constexpr double kRadiusTolerance = 0.1;
constexpr double kBandFraction = 0.03;
constexpr double kMinCapHalfAngleDeg = 25;
constexpr double kMaxInsideFraction = 0.1;
constexpr int kMinSpherePoints = 20;

}  // namespace

std::vector<std::string> MarkSpherePoints(const calib::RefineSphere& sphere,
                                          calib::RigRefinementData* data) {
  const double r0 = 0.5 * sphere.diameter_mm;
  std::vector<std::string> log;
  int views = 0;
  for (const calib::RefinePhasePoint& p : data->points) views = std::max(views, p.view + 1);
  eval::VdiOptions vdi;
  vdi.inlier_band_mm = kBandFraction * r0;
  vdi.radius_tolerance = kRadiusTolerance;
  vdi.min_points = kMinSpherePoints;
  for (int v = 0; v < views; ++v) {
    std::vector<size_t> idx;
    PointCloud cloud;
    for (size_t i = 0; i < data->points.size(); ++i) {
      if (data->points[i].view != v) continue;
      idx.push_back(i);
      cloud.points.push_back(data->points[i].p_in_left);
    }
    if (idx.empty()) continue;
    const eval::SphereResult found = eval::EvaluateSphere(cloud, sphere.diameter_mm, vdi);
    if (!found.ok()) {
      log.push_back(StrCat("view ", v, ": no sphere of diameter ", sphere.diameter_mm,
                           " mm: ", found.message));
      continue;
    }
    const double r = 0.5 * found.diameter_mm;
    std::vector<size_t> on;
    int inside = 0;
    Eigen::Vector3d direction_sum = Eigen::Vector3d::Zero();
    for (size_t i : idx) {
      const Eigen::Vector3d d = data->points[i].p_in_left - found.centre;
      const double n = d.norm();
      if (n < r - vdi.inlier_band_mm) {
        ++inside;
      } else if (n < r + vdi.inlier_band_mm && n > 0) {
        on.push_back(i);
        direction_sum += d / n;
      }
    }
    const double mean_direction = on.empty() ? 1 : direction_sum.norm() / on.size();
    const double max_mean_direction = 0.5 * (1 + std::cos(kMinCapHalfAngleDeg * M_PI / 180));
    std::string why;
    if (std::abs(r - r0) > kRadiusTolerance * r0) {
      why = StrCat("its fitted diameter ", util::Fixed(2 * r, 3), " mm is not the certified one");
    } else if (static_cast<int>(on.size()) < kMinSpherePoints) {
      why = StrCat(on.size(), " points on it (at least ", kMinSpherePoints, " needed)");
    } else if (mean_direction > max_mean_direction) {
      why = StrCat("its points cover a cap of less than ", kMinCapHalfAngleDeg, " degrees");
    } else if (inside > kMaxInsideFraction * static_cast<double>(on.size())) {
      why = StrCat(inside, " points lie inside it");
    }
    if (!why.empty()) {
      log.push_back(StrCat("view ", v, ": a sphere candidate left out: ", why));
      continue;
    }
    const int k = static_cast<int>(data->spheres.size());
    data->spheres.push_back({v, found.centre});
    for (size_t i : on) data->points[i].sphere = k;
    log.push_back(StrCat("view ", v, ": the sphere, ", on.size(), " points, fitted diameter ",
                         util::Fixed(2 * r, 3), " mm"));
  }
  return log;
}

void RefineOptions::Check() const {
  util::CheckOption(points_per_view >= 0, "RefineOptions", "points_per_view", points_per_view,
                    "must be >= 0");
  CalibrationFiles::Check("RefineOptions");
  rig.Check();
  reconstruction.Check();
  markers.Check();
}

std::string RefineSummary::BriefReport() const {
  return StrCat(refinement.BriefReport(), " [rig from ", calibration_source, "]");
}

nlohmann::json ToJson(const RefineSummary& s) {
  nlohmann::json j = ToJson(s.refinement);
  j["calibration"] = s.calibration_source;
  j["gather_s"] = s.gather_s;
  j["solve_s"] = s.solve_s;
  return j;
}

StereoRig ReadScanRig(const scan::ScanFolder& folder, const CalibrationFiles& files,
                      std::string* source) {
  const scan::ScanManifest& m = folder.manifest();
  RigReadOptions read;
  read.devices = folder.stereo() ? RigDevices::kStereo : RigDevices::kCameraProjector;
  read.camera_width = m.image_width;
  read.camera_height = m.image_height;
  if (std::optional<ResolvedRig> r = LookUpRig(files, read, {folder.root() / "rig.json"})) {
    *source = std::move(r->source);
    return std::move(r->rig);
  }
  throw Error(StrCat("refine: ", folder.root().string(),
                     ": no rig to refine: give --calib or --opencv, or put rig.json in the scan "
                     "folder"));
}

void AddViewToRefinement(const StereoRig& rig, int view, const stereo::ViewReconstruction& rec,
                         const RefineOptions& options, calib::RigRefinementData* data) {
  const size_t v = static_cast<size_t>(view);
  if (data->right_phase.size() <= v) data->right_phase.resize(v + 1);
  const registration::ViewMarkers markers = registration::DetectViewMarkers(
      rig, rec.texture_left, rec.texture_right, rec.cloud, options.markers);
  for (const registration::ViewMarker& m : markers.markers) {
    data->markers.push_back({view, m.left_px, m.right_px, m.centre_in_sensor});
  }
  if (options.points_per_view == 0 || rec.phase_right.empty()) return;
  const OrganizedPointCloud& cloud = rec.cloud;
  const size_t valid = cloud.NumValid();
  if (valid == 0) return;
  // Evenly over the measured pixels: every k-th, k from the count.
  const size_t stride = std::max<size_t>(1, valid / static_cast<size_t>(options.points_per_view));
  data->right_phase[v] = rec.phase_right.isContinuous() ? rec.phase_right : rec.phase_right.clone();
  size_t k = 0;
  for (int r = 0; r < cloud.height; ++r) {
    for (int c = 0; c < cloud.width; ++c) {
      const size_t i = cloud.index(c, r);
      if (!cloud.valid[i] || (k++ % stride) != 0) continue;
      const float phi = rec.phase_left.at<float>(r, c);
      const Eigen::Vector3d& p = cloud.cloud.points[i];
      const Eigen::Vector3d p_right = rig.right_from_left * p;
      if (!std::isfinite(phi) || !(p_right.z() > 0)) continue;
      if (!PhaseValidAround(data->right_phase[v], rig.right.Project(p_right))) continue;
      data->points.push_back({view, Eigen::Vector2d(c, r), phi, p});
    }
  }
}

RefineResult RefineRigFromScan(const scan::ScanFolder& folder, const StereoRig& rig,
                               const RefineOptions& options) {
  options.Check();
  if (!folder.stereo()) {
    throw Error(
        StrCat("refine: ", folder.layout().Manifest().string(),
               " says 'cameras': 1: refinement needs two cameras (in a camera + projector view the "
               "projector is what triangulates a point; nothing redundant is left with one fringe "
               "direction)"));
  }
  const scan::ScanManifest& manifest = folder.manifest();
  for (const auto& [cam, name] : {std::pair{&rig.left, "left"}, std::pair{&rig.right, "right"}}) {
    if (cam->width != manifest.image_width || cam->height != manifest.image_height) {
      throw Error(StrCat("refine: the rig's ", name, " camera is calibrated at ", cam->width, " x ",
                         cam->height, " px, but ", folder.layout().Manifest().string(),
                         " says the images are ", manifest.image_width, " x ",
                         manifest.image_height));
    }
  }
  calib::RigRefinementOptions rig_options = options.rig;
  if (!options.artefact.empty()) {
    const eval::Artefact artefact = eval::ReadArtefact(options.artefact);
    if (!artefact.sphere) {
      throw Error(StrCat("refine: ", options.artefact.string(),
                         ": the artefact has no sphere (the shape constraint needs its certified "
                         "diameter)"));
    }
    calib::RefineSphere sphere;
    sphere.diameter_mm = artefact.sphere->diameter_mm;
    // The certificate's uncertainty when it is larger than the default form noise.
    sphere.sigma_mm = std::max(sphere.sigma_mm, artefact.sphere->uncertainty_mm);
    rig_options.sphere = sphere;
  }
  const phase::PatternScheme scheme = folder.ReadScheme();
  const stereo::ViewReconstructor reconstructor(rig, scheme, options.reconstruction);
  RefineResult result;
  util::Timer timer;
  calib::RigRefinementData data;
  const std::vector<std::string>& names = folder.views();
  data.right_phase.resize(names.size());
  util::Progress progress("refine: read views", static_cast<int>(names.size()));
  for (size_t v = 0; v < names.size(); ++v) {
    const auto left = folder.ReadExposureStacks(names[v], scan::Camera::kLeft, scheme);
    const auto right = folder.ReadExposureStacks(names[v], scan::Camera::kRight, scheme);
    stereo::ViewReconstruction rec = reconstructor.Reconstruct(left, right);
    progress.Advance();
    if (!rec.summary.ok()) {
      util::LogWarning(StrCat("refine: view ", names[v], " left out: ", rec.summary.message));
      continue;
    }
    AddViewToRefinement(rig, static_cast<int>(v), rec, options, &data);
  }
  result.summary.gather_s = timer.ElapsedSeconds();
  timer.Restart();
  if (rig_options.sphere) {
    for (const std::string& line : MarkSpherePoints(*rig_options.sphere, &data)) {
      util::LogInfo("refine: " + line);
    }
  }
  calib::RigRefinement refined = calib::RefineRig(rig, data, rig_options);
  result.summary.solve_s = timer.ElapsedSeconds();
  result.rig = refined.rig;
  result.summary.refinement = std::move(refined.summary);
  return result;
}

RefineResult RefineScanRig(const fs::path& project, const fs::path& out_rig,
                           const RefineOptions& options) {
  options.Check();
  util::RequireDirectory(project, "scan folder");
  const scan::ScanFolder folder = scan::ScanFolder::Open(project);
  if (!folder.has_views()) throw Error(StrCat("refine: ", project.string(), ": no views"));
  std::vector<fs::path> inputs = {project};
  for (const fs::path& p : options.Files()) inputs.push_back(p);
  if (!options.artefact.empty()) inputs.push_back(options.artefact);
  util::CheckOutputFile(out_rig, inputs);
  std::string source;
  const StereoRig rig = ReadScanRig(folder, options, &source);
  RefineResult r = RefineRigFromScan(folder, rig, options);
  r.summary.calibration_source = source;
  if (r.summary.ok()) io::WriteRig(out_rig, r.rig, {{"refinement", ToJson(r.summary)}});
  return r;
}

}  // namespace fringe::pipeline
