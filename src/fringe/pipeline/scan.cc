#include "fringe/pipeline/scan.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <mutex>
#include <optional>

#include "fringe/calib/calibrate_folder.h"
#include "fringe/calib/diagnostics.h"
#include "fringe/calib/projector_folder.h"
#include "fringe/eval/deviation.h"
#include "fringe/fusion/tiles.h"
#include "fringe/geometry/align.h"
#include "fringe/geometry/point_index.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/ply.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/pipeline/memory_budget.h"
#include "fringe/pipeline/report.h"
#include "fringe/pipeline/result_layout.h"
#include "fringe/pipeline/scan_model.h"
#include "fringe/pipeline/view_checkpoint.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/registration_io.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/stereo/camera_projector.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/format.h"
#include "fringe/util/log.h"
#include "fringe/util/memory.h"
#include "fringe/util/timer.h"

namespace fringe::pipeline {
namespace {

using internal::BuildReport;
using internal::Calibration;
using internal::DisplayFromViews;
using internal::EvaluateAgainstTruth;
using internal::kPictureWidthPx;
using internal::Model;
using internal::PhasePicture;
using internal::Rms;
using internal::Stride;
using internal::TextureWithMarkers;
using internal::ViewPictures;

namespace fs = std::filesystem;
using nlohmann::json;
using util::Fixed;
using util::StrCat;

// Truth figures are NaN without truth (a real scan): null in JSON.
json figure(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

// One write of the scan's output. Its failure (a full disk, a quota, a file size limit) fails
// the scan whatever keep_going says, with an error naming the stage and the file (the writers
// name it; util::WriteFolderAtomically shows it inside OUT, not the temporary folder).
template <class Write>
void WriteOutput(const char* stage, const fs::path& out, Write&& write) {
  try {
    write();
  } catch (const Error& e) {
    throw Error(
        StrCat("scan: stage '", stage, "': ", e.what(), "; nothing was written to ", out.string()));
  }
}

// A camera + projector scan needs the projector calibrated as an inverse camera.
void RequireProjector(const scan::ScanFolder& folder, const Calibration& c) {
  if (folder.stereo() || c.rig.projector) return;
  throw Error(StrCat("scan: ", c.source, ": the rig has no calibrated projector, but ",
                     folder.layout().Manifest().string(),
                     " says 'cameras': 1 (camera + projector views need the projector's "
                     "intrinsics and projector_from_left: `fringe calibrate` on a projector "
                     "calibration folder, docs/scan-folder.md)"));
}

// The rig and the scan folder both describe the sensor: each camera's image size must be the
// manifest's, and a camera + projector scan's schemes must be for the rig's projector (a scheme
// for another projector decodes to columns of that one: every point wrong, none missing).
// Checked before any view is read; the error names both files.
void CheckRigFitsScan(const scan::ScanFolder& folder,
                      const std::vector<phase::PatternScheme>& schemes, const Calibration& c) {
  const scan::ScanManifest& m = folder.manifest();
  const std::string manifest = folder.layout().Manifest().string();
  auto camera = [&](const CameraModel& cam, const char* name) {
    if (cam.width != m.image_width || cam.height != m.image_height) {
      throw Error(StrCat("scan: ", c.source, ": the ", name, " camera is calibrated at ", cam.width,
                         " x ", cam.height, " px, but ", manifest, " says the images are ",
                         m.image_width, " x ", m.image_height));
    }
  };
  camera(c.rig.left, "left");
  if (folder.stereo()) camera(c.rig.right, "right");
  if (folder.stereo() || !c.rig.projector) return;
  for (size_t k = 0; k < schemes.size(); ++k) {
    const phase::PatternScheme& s = schemes[k];
    if (!stereo::SchemeFitsProjector(s, *c.rig.projector)) {
      throw Error(
          StrCat("scan: ",
                 (k == 0 ? folder.layout().Scheme() : folder.layout().HorizontalScheme()).string(),
                 ": the scheme '", s.name, "' is for a ", s.projector_width, " x ",
                 s.projector_height, " projector, but ", c.source, " calibrates a ",
                 c.rig.projector->width, " x ", c.rig.projector->height, " projector"));
    }
  }
}

// The rig: options first, then PROJECT/rig.json, then PROJECT/calibration/ board images (a
// stereo calibration, or for one camera a camera + projector calibration of board pose folders).
Calibration ResolveCalibration(const scan::ScanFolder& folder, const phase::PatternScheme& scheme,
                               const ScanOptions& options, int width, int height) {
  const fs::path& project = folder.root();
  Calibration c;
  // The files given (any kind, calibration_files.h), else PROJECT/rig.json.
  RigReadOptions read;
  read.devices = folder.stereo() ? RigDevices::kStereo : RigDevices::kCameraProjector;
  read.camera_width = width;
  read.camera_height = height;
  read.projector_width = scheme.projector_width;
  read.projector_height = scheme.projector_height;
  read.stereo_needed_by = project.string() + " is a stereo scan";
  if (std::optional<ResolvedRig> r = LookUpRig(options, read, {folder.layout().Rig()})) {
    c.rig = std::move(r->rig);
    c.source = std::move(r->source);
    RequireProjector(folder, c);
    return c;
  }
  const fs::path cal_dir = folder.layout().CalibrationDir();
  if (!folder.has_calibration()) {
    throw Error(StrCat("scan: ", project.string(),
                       ": no calibration: give --calib, or put rig.json or calibration/ board "
                       "images (with target.json) in the scan folder"));
  }
  c.target = folder.ReadTarget();
  const CalibrationTarget& target = c.target;
  util::LogInfo("scan: calibrating from " + cal_dir.string());
  if (!folder.stereo()) {
    calib::ProjectorFolderCalibration cal =
        calib::CalibrateProjectorFolder(cal_dir, target, options.projector_calibration);
    if (!cal.ok()) {
      throw Error(StrCat("scan: ", cal_dir.string(),
                         ": camera + projector calibration failed: ", cal.message()));
    }
    c.rig = cal.rig;
    c.source = StrCat("calibration/ of the scan folder (", cal.names.size(),
                      " board poses, camera + projector)");
    c.projector_folder = std::move(cal);
    return c;
  }
  calib::FolderCalibration cal = calib::CalibrateFolder(cal_dir, target);
  if (!cal.stereo) {
    throw Error(StrCat("scan: ", cal_dir.string(),
                       ": calibration: the images are of one camera; the scanner needs left/ and "
                       "right/ board images"));
  }
  if (!cal.success()) {
    throw Error(
        StrCat("scan: ", cal_dir.string(), ": calibration failed: ", cal.pair.summary.message));
  }
  c.rig = cal.pair.rig;
  // Relative to the scan folder: the report and summary stay the same wherever it lies.
  c.source = StrCat("calibration/ of the scan folder (", cal.names.size(), " board pairs)");
  c.folder = std::move(cal);
  return c;
}

// OUT/rig.json: the rig used, with the calibration figures when it was calibrated here.
void WriteRigOf(const Calibration& c, const fs::path& path) {
  if (c.folder) {
    calib::WriteFolderCalibration(path, *c.folder);
  } else if (c.projector_folder) {
    io::WriteRig(path, c.rig, {{"calibration", CalibrationToJson(*c.projector_folder)}});
  } else {
    io::WriteRig(path, c.rig);
  }
}

// One camera + projector: every scheme's stack (one direction, or vertical and horizontal) at
// every exposure, arranged as the reconstructor takes them (exposure-major further exposures).
stereo::ViewStacks ReadOneCameraStacks(const scan::ScanFolder& folder, const std::string& name,
                                       const std::vector<phase::PatternScheme>& schemes) {
  std::vector<std::vector<std::vector<cv::Mat>>> stacks =
      folder.ReadViewStacks(name, scan::Camera::kLeft, schemes);  // [scheme][exposure]
  stereo::ViewStacks out;
  for (auto& exposures : stacks) out.left.push_back(std::move(exposures.front()));
  for (size_t e = 1; e < stacks.front().size(); ++e) {
    for (auto& exposures : stacks) out.more_left_exposures.push_back(std::move(exposures[e]));
  }
  return out;
}

// OUT/views/NNN.ply of a view that worked; a failure fails the view in stage "write".
// The valid points of `grid` and their normals, in grid order (as Compact(), without the
// attributes): all that registration, the report's residuals and the truth comparison read of a
// view, held for every view at once.
PointCloud CompactGeometry(const OrganizedPointCloud& grid) {
  PointCloud out;
  const size_t n = grid.NumValid();
  const bool normals = grid.cloud.has_normals();
  out.points.reserve(n);
  if (normals) out.normals.reserve(n);
  for (size_t i = 0; i < grid.valid.size(); ++i) {
    if (!grid.valid[i]) continue;
    out.points.push_back(grid.cloud.points[i]);
    if (normals) out.normals.push_back(grid.cloud.normals[i]);
  }
  return out;
}

void WriteViewCloud(const fs::path& out_dir, ViewResult* v) {
  ScanViewSummary& s = v->summary;
  if (!s.ok) return;
  try {
    io::WritePly(ResultLayout{out_dir}.ViewCloud(s.name), v->cloud,
                 io::PlyFormat::kBinaryLittleEndian,
                 {StrCat("fringe scan: view ", s.name,
                         ", left camera (sensor) frame, mm; quality = fringe modulation (DN)")});
  } catch (const Error& e) {
    s.ok = false;
    s.failed_stage = "write";
    s.message = e.what();
  } catch (const cv::Exception& e) {
    s.ok = false;
    s.failed_stage = "write";
    s.message = StrCat(ResultLayout{out_dir}.ViewCloud(s.name).string(), ": ", e.what());
  }
}

// Reads, reconstructs and writes one view. Data failures come back in the summary (ok = false,
// the stage and the reason); nothing is thrown for them so that other views go on.
ViewResult ProcessView(const scan::ScanFolder& folder, const std::string& name,
                       const std::vector<phase::PatternScheme>& schemes, const StereoRig& rig,
                       const stereo::ViewReconstructor& reconstructor, const ScanOptions& options,
                       bool keep_phase, const fs::path& out_dir) {
  ViewResult v;
  ScanViewSummary& s = v.summary;
  s.name = name;
  const fs::path view_dir = folder.layout().ViewDir(name);
  std::string stage = "read";
  try {
    util::Timer timer;
    // One stack or several exposures per camera (phase/stack_io.h); one camera: left only, one
    // or both fringe directions. The two cameras' PNGs are decoded at the same time (the reads
    // of a stack are serial).
    const phase::PatternScheme& scheme = schemes.front();
    std::vector<std::vector<cv::Mat>> left, right;
    stereo::ViewStacks one_camera;
    tbb::parallel_invoke(
        [&] {
          if (folder.stereo()) {
            left = folder.ReadExposureStacks(name, scan::Camera::kLeft, scheme);
          } else {
            one_camera = ReadOneCameraStacks(folder, name, schemes);
          }
        },
        [&] {
          if (folder.stereo())
            right = folder.ReadExposureStacks(name, scan::Camera::kRight, scheme);
        });
    s.read_s = timer.ElapsedSeconds();
    stage = "reconstruct";
    stereo::ViewReconstruction rec = folder.stereo() ? reconstructor.Reconstruct(left, right)
                                                     : reconstructor.Reconstruct(one_camera);
    if (rec.summary.ok() && options.write_report) {
      v.pictures.push_back(PhasePicture(name, rec.phase_left, kPictureWidthPx));
    }
    left.clear();
    right.clear();
    one_camera = {};
    s.decode_s = rec.summary.decode_s;
    s.reconstruct_s = rec.summary.total_s - rec.summary.decode_s;
    const double pixels = double(rec.cloud.width) * rec.cloud.height;
    s.decode_valid_left = rec.summary.decode_left.valid / std::max(1.0, pixels);
    s.decode_valid_right = rec.summary.decode_right.valid / std::max(1.0, pixels);
    if (!rec.summary.ok()) {
      throw Error(StrCat(view_dir.string(), ": ", stereo::ToString(rec.summary.status), ": ",
                         rec.summary.message));
    }
    s.points = rec.summary.points;
    s.valid_fraction = s.points / std::max(1.0, pixels);
    // The phase is dropped with the view's images: the projector figures of the drift check
    // are taken now (the markers' come after the view stage).
    if (options.check_drift && folder.stereo()) {
      MeasureProjectorConsistency(rig, rec.cloud, rec.phase_left, options.drift, &s.drift);
    }
    for (ReportImage& p : ViewPictures(name, rec.cloud)) v.pictures.push_back(std::move(p));
    if (options.detect_markers) {
      stage = "markers";
      timer.Restart();
      // Stereo: triangulated from both textures; one camera: the ring centre's ray against the
      // measured surface.
      registration::ViewMarkers markers =
          folder.stereo()
              ? registration::DetectViewMarkers(rig, rec.texture_left, rec.texture_right, rec.cloud,
                                                options.markers)
              : registration::DetectViewMarkersOneCamera(rig.left, rec.texture_left, rec.cloud,
                                                         options.markers);
      s.markers = static_cast<int>(markers.markers.size());
      v.markers = std::move(markers.markers);
      s.markers_s = timer.ElapsedSeconds();
    }
    v.pictures.push_back(
        {StrCat("view ", name, ": left texture (decoded fringe background) with the ", s.markers,
                " measured markers circled"),
         TextureWithMarkers(rec.texture_left, v.markers, rig, 480)});
    stage = "write";
    if (options.detect_markers) {
      registration::WriteViewMarkers(ResultLayout{out_dir}.ViewMarkers(name), v.markers);
    }
    v.cloud = std::move(rec.cloud);
    s.ok = true;
    // With the projector-column check (it needs every view) the cloud is written after it;
    // else here, while the next views decode.
    if (keep_phase) {
      v.phase_left = rec.phase_left;
    } else {
      WriteViewCloud(out_dir, &v);
    }
  } catch (const Error& e) {
    s.ok = false;
    s.failed_stage = stage;
    s.message = e.what();
  } catch (const cv::Exception& e) {
    s.ok = false;
    s.failed_stage = stage;
    s.message = StrCat(view_dir.string(), ": ", e.what());
  }
  return v;
}

// Projector-less stereo: the projector's columns fitted to every view's points and left phases
// (at most ~200 000 pairs, every k-th valid point), then each view's points off their column
// dropped when the fit is accepted (ScanOptions::fit_projector_columns).
void CheckProjectorColumns(const ScanOptions& options, std::vector<ViewResult>* results,
                           ScanSummary* s) {
  constexpr int64_t kMaxPairs = 200000;
  const double tolerance = options.reconstruction.matching.max_projector_error_px;
  int64_t valid = 0;
  for (const ViewResult& v : *results) {
    if (v.summary.ok) valid += static_cast<int64_t>(v.cloud.NumValid());
  }
  const int stride = static_cast<int>(std::max<int64_t>(1, (valid + kMaxPairs - 1) / kMaxPairs));
  std::vector<Eigen::Vector3d> points;
  std::vector<double> columns;
  for (const ViewResult& v : *results) {
    if (v.summary.ok)
      stereo::SampleProjectorColumns(v.cloud, v.phase_left, stride, &points, &columns);
  }
  stereo::ProjectorColumnFitOptions fit_options = options.projector_columns;
  fit_options.max_error_px = tolerance;
  const stereo::ProjectorColumnFit fit = stereo::FitProjectorColumns(points, columns, fit_options);
  s->projector_columns_used = fit.ok;
  s->projector_column_rejected = 0;
  if (fit.ok) {
    tbb::parallel_for(size_t{0}, results->size(), [&](size_t i) {
      ViewResult& v = (*results)[i];
      if (!v.summary.ok) return;
      const int removed =
          stereo::RejectByProjectorColumns(fit.model, v.phase_left, tolerance, &v.cloud);
      v.summary.projector_column_rejected = removed;
      v.summary.points -= removed;
      v.summary.valid_fraction =
          v.summary.points / std::max(1.0, double(v.cloud.width) * v.cloud.height);
    });
    for (const ViewResult& v : *results)
      s->projector_column_rejected += v.summary.projector_column_rejected;
  }
  for (ViewResult& v : *results) v.phase_left.release();
  util::LogInfo(
      StrCat("scan: projector columns ", fit.ok ? "used" : "not used", ": ", fit.message,
             fit.ok ? StrCat("; ", s->projector_column_rejected, " points dropped") : ""));
  const auto& r = fit.model.rows;
  s->projector_columns = {
      {"used", fit.ok},
      {"message", fit.message},
      {"pairs", fit.num_points},
      {"inliers", fit.num_inliers},
      {"rms_px", fit.rms_px},
      {"thickness", fit.thickness},
      {"tolerance_px", tolerance},
      {"rejected_points", s->projector_column_rejected},
      {"rows", {{r(0, 0), r(0, 1), r(0, 2), r(0, 3)}, {r(1, 0), r(1, 1), r(1, 2), r(1, 3)}}}};
}

// The drift verdict of every view that worked (pipeline/drift.h) and the scan's: the markers'
// epipolar residual (stereo) or the two-direction residual (one camera, both directions), with
// the projector figures ProcessView took.
void CheckDrift(const scan::ScanFolder& folder, size_t num_schemes, const StereoRig& rig,
                const ScanOptions& options, std::vector<ViewResult>* results, ScanSummary* s) {
  s->drift_options = options.drift;
  std::vector<const ViewDrift*> checked;
  std::vector<std::string> drifted;
  for (ViewResult& v : *results) {
    if (!v.summary.ok) continue;
    ViewDrift& d = v.summary.drift;
    if (folder.stereo()) {
      MeasureMarkerEpipolar(rig, v.markers, &d);
    } else if (num_schemes >= 2) {
      MeasureTwoDirectionResidual(v.cloud, &d);
    }
    DecideDrift(options.drift, &d);
    if (!d.checked) continue;
    checked.push_back(&d);
    ++s->drift_views_checked;
    for (const std::string& e : d.evidence) {
      // "markers (23 in both images)" -> "markers": the kinds of evidence over the scan.
      const std::string kind = e.substr(0, e.find(" ("));
      if (std::find(s->drift_evidence.begin(), s->drift_evidence.end(), kind) ==
          s->drift_evidence.end()) {
        s->drift_evidence.push_back(kind);
      }
    }
    if (d.drift) drifted.push_back(StrCat("view ", v.summary.name, ": ", d.message));
  }
  s->epipolar_rms_px = PooledEpipolarRmsPx(checked);
  s->calibration_drift = !drifted.empty();
  for (const std::string& w : drifted) util::LogWarning("scan: " + w);
  if (s->drift_views_checked == 0) {
    util::LogInfo("scan: calibration drift not checked: no view had redundant evidence");
  }
}

// Signed point-to-plane distances of sampled points of every placed view to the nearest point of
// every other placed view (its normal), kept within threshold_mm: the residuals ICP minimises.
std::vector<double> OverlapResiduals(const std::vector<const PointCloud*>& clouds,
                                     const std::vector<Rigid3d>& world_from_sensor,
                                     double threshold_mm) {
  constexpr size_t kTargetPoints = 150000, kSamples = 3000;
  // Views in parallel (trees, then queries); the residuals are concatenated in view order.
  std::vector<std::unique_ptr<PointIndex>> index(clouds.size());
  std::vector<std::vector<size_t>> target_ids(clouds.size());
  tbb::parallel_for(size_t{0}, clouds.size(), [&](size_t v) {
    target_ids[v] = Stride(clouds[v]->size(), kTargetPoints);
    std::vector<Eigen::Vector3d> p;
    p.reserve(target_ids[v].size());
    for (size_t i : target_ids[v]) p.push_back(world_from_sensor[v] * clouds[v]->points[i]);
    index[v] = std::make_unique<PointIndex>(std::move(p));
  });
  std::vector<std::vector<double>> per_view(clouds.size());
  tbb::parallel_for(size_t{0}, clouds.size(), [&](size_t v) {
    for (size_t i : Stride(clouds[v]->size(), kSamples)) {
      const Eigen::Vector3d p = world_from_sensor[v] * clouds[v]->points[i];
      for (size_t u = 0; u < clouds.size(); ++u) {
        if (u == v) continue;
        const auto [k, d2] = index[u]->Nearest(p);
        if (d2 > threshold_mm * threshold_mm) continue;
        const size_t j = target_ids[u][k];
        const Eigen::Vector3d n = world_from_sensor[u].RotateDirection(clouds[u]->normals[j]);
        if (!n.allFinite()) continue;
        per_view[v].push_back((p - world_from_sensor[u] * clouds[u]->points[j]).dot(n));
      }
    }
  });
  std::vector<double> out;
  for (const std::vector<double>& r : per_view) out.insert(out.end(), r.begin(), r.end());
  return out;
}

int ViewsInFlight(const fs::path& project, const scan::ScanFolder& folder,
                  const std::vector<phase::PatternScheme>& schemes, const ScanOptions& options,
                  double limit_gib) {
  constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;
  const scan::ScanManifest& m = folder.manifest();
  int images = 0;
  for (const phase::PatternScheme& sc : schemes) images += sc.NumImages();
  const double pixels = double(m.image_width) * m.image_height;
  // A view in flight, and the grid it leaves for the later stages.
  const double view_gib =
      (ViewWorkBytes(m.image_width, m.image_height, images, m.cameras, m.bit_depth) +
       kGridBytesPerSlot * pixels) /
      kGiB;
  const double in_use_gib = util::CurrentMemoryGiB();
  const double free_gib = limit_gib - in_use_gib;
  if (free_gib < view_gib) {
    throw Error(StrCat("scan: ", project.string(), ": the memory limit of ", Fixed(limit_gib, 3),
                       " GiB (--memory-limit) is too small for one view: a view of ", m.cameras,
                       " x ", images, " images of ", m.image_width, " x ", m.image_height,
                       " px needs ~", Fixed(view_gib, 3), " GiB to reconstruct, and ",
                       Fixed(in_use_gib, 3), " GiB are in use already"));
  }
  return std::clamp(static_cast<int>(free_gib / view_gib), 1, options.views_in_flight);
}

void HandleFailures(const fs::path& project, const fs::path& out, bool keep_going, ScanSummary* s) {
  std::vector<std::string> failed, worked;
  bool output_failed = false;  // a view's files could not be written: fatal even with keep_going
  s->views_ok = 0;
  s->points = 0;
  for (const ScanViewSummary& v : s->views) {
    if (v.ok) {
      ++s->views_ok;
      s->points += v.points;
      worked.push_back(v.name);
    } else {
      failed.push_back(
          StrCat("view ", v.name, " failed in stage '", v.failed_stage, "': ", v.message));
      output_failed = output_failed || v.failed_stage == "write";
    }
  }
  if (failed.empty()) return;
  std::string list;
  for (const std::string& f : failed) list += (list.empty() ? "" : "; ") + f;
  if (!keep_going || worked.empty() || output_failed) {
    std::string ok_list;
    for (const std::string& w : worked) ok_list += (ok_list.empty() ? "" : ", ") + w;
    throw Error(StrCat("scan: ", project.string(), ": ", list,
                       worked.empty()  ? std::string("; no view worked")
                       : output_failed ? StrCat("; views that worked: ", ok_list,
                                                " (the output could not be written: "
                                                "--keep-going does not leave such views out)")
                                       : StrCat("; views that worked: ", ok_list,
                                                " (--keep-going finishes without the failed "
                                                "ones)"),
                       "; nothing was written to ", out.string()));
  }
  if (s->message != StrCat(failed.size(), " view(s) left out: ", list)) {
    s->status = ScanStatus::kPartial;
    s->message = StrCat(failed.size(), " view(s) left out: ", list);
    util::LogWarning(s->message);
  }
}

}  // namespace

void ScanOptions::Check() const {
  util::CheckOption(views_in_flight >= 1 && views_in_flight <= 64, "ScanOptions", "views_in_flight",
                    views_in_flight, "must be in [1, 64]");
  util::CheckOption(std::isfinite(memory_limit_gib) && memory_limit_gib >= 0, "ScanOptions",
                    "memory_limit_gib", memory_limit_gib,
                    "must be >= 0 (0: half the machine's memory)");
  util::CheckOption(std::isfinite(fusion_tile_mm) && fusion_tile_mm >= 0, "ScanOptions",
                    "fusion_tile_mm", fusion_tile_mm,
                    "must be >= 0 (0: chosen from the memory limit)");
  util::CheckOption(std::isfinite(tolerance_mm) && tolerance_mm >= 0, "ScanOptions", "tolerance_mm",
                    tolerance_mm, "must be >= 0 (0: the colour range from the data)");
  CalibrationFiles::Check("ScanOptions");
  projector_calibration.Check();
  reconstruction.Check();
  projector_columns.Check();
  drift.Check();
  if (refine) refine_options.Check();
  registration.Check();
  fusion.Check();
  mesh.Check();
}

const char* ToString(ScanStatus s) {
  switch (s) {
    case ScanStatus::kOk:
      return "ok";
    case ScanStatus::kPartial:
      return "partial";
  }
  return "?";
}

std::string ScanSummary::BriefReport() const {
  std::string s = StrCat(
      "scan: ", ToString(status), ", ", views_ok, " of ", views.size(), " views, ", points,
      " points in ", Fixed(total_s, 2), " s (read ", Fixed(read_s, 2), " s, decode ",
      Fixed(decode_s, 2), " s, reconstruct ", Fixed(reconstruct_s, 2),
      " s summed over views; "
      "views ",
      Fixed(views_s, 2), " s wall; register ", Fixed(register_s, 2), " s, fuse ", Fixed(fuse_s, 2),
      " s, mesh ", Fixed(mesh_s, 2), " s), ", fused_points, " fused points, mesh of ",
      mesh_triangles, " triangles, peak memory ", Fixed(peak_mem_gib, 2), " GiB");
  if (has_truth) {
    s += StrCat("; against the truth: pose error max ", Fixed(pose_rot_err_deg, 4), " deg / ",
                Fixed(pose_trans_err_mm, 4), " mm, single-view RMS in the overlaps ",
                Fixed(single_view_rms_mm, 4), " mm, fused RMS ", Fixed(fused_rms_mm, 4),
                " mm (merged points ", Fixed(fused_overlap_rms_mm, 4), " mm)");
  }
  if (calibration_drift) s += "; WARNING: calibration drift (see the views' drift check)";
  if (!message.empty()) s += ": " + message;
  return s;
}

json FiguresJson(const ScanSummary& s) {
  return {
      {"views", s.views.size()},
      {"views_ok", s.views_ok},
      {"views_resumed", s.views_resumed},
      {"checkpoint_s", s.checkpoint_s},
      {"checkpoint_mib", s.checkpoint_mib},
      {"points", s.points},
      {"fused_points", s.fused_points},
      {"mesh_vertices", s.mesh_vertices},
      {"mesh_triangles", s.mesh_triangles},
      {"calibrate_s", s.calibrate_s},
      {"read_s", s.read_s},
      {"decode_s", s.decode_s},
      {"reconstruct_s", s.reconstruct_s},
      {"markers_s", s.markers_s},
      {"views_s", s.views_s},
      {"register_s", s.register_s},
      {"fuse_s", s.fuse_s},
      {"mesh_s", s.mesh_s},
      {"report_s", s.report_s},
      {"total_s", s.total_s},
      {"evaluate_s", s.evaluate_s},
      {"calibrate_cpu_s", s.calibrate_cpu_s},
      {"views_cpu_s", s.views_cpu_s},
      {"register_cpu_s", s.register_cpu_s},
      {"fuse_cpu_s", s.fuse_cpu_s},
      {"mesh_cpu_s", s.mesh_cpu_s},
      {"report_cpu_s", s.report_cpu_s},
      {"total_cpu_s", s.total_cpu_s},
      {"evaluate_cpu_s", s.evaluate_cpu_s},
      {"peak_mem_gib", s.peak_mem_gib},
      {"memory_limit_gib", s.memory_limit_gib},
      {"views_in_flight", s.views_in_flight},
      {"fusion_tiles", s.fusion_tiles},
      {"fusion_tile_mm", std::isfinite(s.fusion_tile_mm) ? json(s.fusion_tile_mm) : json(nullptr)},
      {"marker_adjusted_rms_mm", s.marker_adjusted_rms_mm},
      {"icp_rms_mm", s.icp_rms_mm},
      {"projector_columns_used", s.projector_columns_used},
      {"projector_column_rejected", s.projector_column_rejected},
      {"pose_rot_err_deg", figure(s.pose_rot_err_deg)},
      {"pose_trans_err_mm", figure(s.pose_trans_err_mm)},
      {"fused_rms_mm", figure(s.fused_rms_mm)},
      {"single_view_rms_mm", figure(s.single_view_rms_mm)},
      {"fused_overlap_rms_mm", figure(s.fused_overlap_rms_mm)},
      {"single_view_sensor_rms_mm", figure(s.single_view_sensor_rms_mm)},
      {"single_view_all_rms_mm", figure(s.single_view_all_rms_mm)},
      {"mesh_rms_mm", figure(s.mesh_rms_mm)},
      {"mesh_truth_rms_mm", figure(s.mesh_truth_rms_mm)},
      {"calibration_drift", s.calibration_drift},
      {"epipolar_rms_px", figure(s.epipolar_rms_px)}};
}

json ToJson(const ScanSummary& s) {
  json j = FiguresJson(s);
  j["status"] = ToString(s.status);
  j["message"] = s.message;
  j["calibration"] = s.calibration_source;
  j["registration_status"] = s.registration_status;
  j["overlap_points"] = s.overlap_points;
  j["clusters"] = s.clusters;
  j["mesh_watertight"] = s.mesh_watertight;
  j["has_truth"] = s.has_truth;
  if (s.has_truth) {
    const Eigen::Matrix<double, 3, 4> g = s.truth_from_world.ToMatrix3x4();
    j["truth_from_world"] = {{g(0, 0), g(0, 1), g(0, 2), g(0, 3)},
                             {g(1, 0), g(1, 1), g(1, 2), g(1, 3)},
                             {g(2, 0), g(2, 1), g(2, 2), g(2, 3)}};
  }
  j["registration"] = s.registration;
  j["fusion"] = s.fusion;
  j["mesh"] = s.meshing;
  j["mode"] = s.stereo ? "stereo" : "camera-projector";
  j["projector_columns"] = s.projector_columns;
  j["refinement"] = s.refinement;
  j["rig_refined"] = s.rig_refined;
  j["drift"] = {{"views_checked", s.drift_views_checked},
                {"evidence", s.drift_evidence},
                {"max_epipolar_systematic_px", s.drift_options.max_epipolar_systematic_px},
                {"min_markers", s.drift_options.min_markers},
                {"min_epipolar_significance", s.drift_options.min_epipolar_significance},
                {"max_projector_bias_px", s.drift_options.max_projector_bias_px},
                {"max_projector_systematic_px", s.drift_options.max_projector_systematic_px},
                {"min_projector_points", s.drift_options.min_projector_points},
                {"max_two_direction_rms_px", s.drift_options.max_two_direction_rms_px}};
  j["calibration_warnings"] = s.calibration_warnings;
  if (!s.calibration_report.empty()) j["calibration_report"] = s.calibration_report;
  if (s.calibration_rms_left_px > 0) {
    j["calibration_rms_left_px"] = s.calibration_rms_left_px;
    if (s.stereo) {
      j["calibration_rms_right_px"] = s.calibration_rms_right_px;
    } else {
      j["calibration_rms_projector_px"] = s.calibration_rms_projector_px;
    }
  }
  json v = json::array();
  for (const ScanViewSummary& e : s.views) {
    json o{{"view", e.name},
           {"ok", e.ok},
           {"points", e.points},
           {"valid_fraction", e.valid_fraction},
           {"decode_valid_left", e.decode_valid_left},
           {"decode_valid_right", e.decode_valid_right},
           {"read_s", e.read_s},
           {"decode_s", e.decode_s},
           {"reconstruct_s", e.reconstruct_s},
           {"markers", e.markers},
           {"markers_s", e.markers_s},
           {"projector_column_rejected", e.projector_column_rejected},
           {"registration_path", e.registration_path},
           {"matched_markers", e.matched_markers},
           {"marker_rms_mm", e.marker_rms_mm},
           {"adjusted_rms_mm", e.adjusted_rms_mm},
           {"overlap_fraction", e.overlap_fraction},
           {"rot_err_deg", figure(e.rot_err_deg)},
           {"trans_err_mm", figure(e.trans_err_mm)},
           {"truth_rms_mm", figure(e.truth_rms_mm)},
           {"epipolar_rms_px", figure(e.drift.epipolar_rms_px)},
           {"drift", e.drift.drift},
           {"drift_check", ToJson(e.drift)}};
    if (!e.ok) {
      o["failed_stage"] = e.failed_stage;
      o["message"] = e.message;
    }
    v.push_back(o);
  }
  j["view_results"] = v;
  return j;
}

ScanSummary RunScan(const fs::path& project, const fs::path& out, const ScanOptions& options) {
  options.Check();
  util::RequireDirectory(project, "scan folder");
  // Inputs are checked before anything is computed: the manifest, the scheme and the views.
  const scan::ScanFolder folder = scan::ScanFolder::Open(project);
  if (!folder.has_views()) throw Error(StrCat("scan: ", project.string(), ": no views"));
  // One scheme; one camera + projector may have a horizontal one too (both directions).
  const std::vector<phase::PatternScheme> schemes = folder.ReadSchemes();
  const phase::PatternScheme& scheme = schemes.front();
  const std::vector<std::string>& names = folder.views();

  ScanSummary s;
  // The memory limit against one view's needs, before anything is written.
  s.memory_limit_gib = ResolveMemoryLimitGiB(options.memory_limit_gib);
  s.views_in_flight = ViewsInFlight(project, folder, schemes, options, s.memory_limit_gib);
  // The output folder must neither be the scan folder nor hold it (replacing it would delete the
  // user's images); checked before the work.
  util::OutputFolderOptions output;
  output.inputs = {project};
  for (const fs::path& f : options.Files()) output.inputs.push_back(f);
  output.resume = options.resume;
  util::CheckOutputFolder(out, output);
  util::WriteFolderAtomically(out, output, [&](const fs::path& dir) {
    const ResultLayout result{dir};
    fs::create_directories(result.ViewsDir());
    // 1. Calibration (its time is reported apart: a rig is calibrated once, not per scan).
    util::Timer timer;
    util::CpuTimer cpu;
    // The image size from the manifest (every stack is checked against it when read).
    Calibration cal = ResolveCalibration(folder, scheme, options, folder.manifest().image_width,
                                         folder.manifest().image_height);
    CheckRigFitsScan(folder, schemes, cal);
    if (options.refine) {
      if (!folder.stereo()) {
        throw Error(StrCat("scan: --refine: ", folder.layout().Manifest().string(),
                           " says 'cameras': 1; refinement needs two cameras"));
      }
      RefineResult r = RefineRigFromScan(folder, cal.rig, options.refine_options);
      r.summary.calibration_source = cal.source;
      s.refinement = ToJson(r.summary);
      s.rig_refined = r.summary.ok();
      if (r.summary.ok()) {
        util::LogInfo("scan: " + r.summary.BriefReport());
        cal.rig = r.rig;
        cal.source += " (refined from this scan)";
      } else {
        util::LogWarning("scan: the rig was not refined: " + r.summary.refinement.message);
      }
    }
    s.stereo = folder.stereo();
    s.calibration_source = cal.source;
    if (cal.folder) {
      s.calibration_rms_left_px = cal.folder->pair.left.summary.final_rms_px;
      s.calibration_rms_right_px = cal.folder->pair.right.summary.final_rms_px;
    } else if (cal.projector_folder) {
      s.calibration_rms_left_px = cal.projector_folder->LeftCamera().summary.final_rms_px;
      s.calibration_rms_projector_px = cal.projector_folder->camera_projector.projector_rms_px;
    }
    WriteOutput("calibrate", out, [&] {
      if (s.rig_refined) {
        io::WriteRig(result.Rig(), cal.rig, {{"refinement", s.refinement}});
      } else {
        WriteRigOf(cal, result.Rig());
      }
    });
    // A rig calibrated here gets what `fringe calibrate --report` gives: its plausibility
    // warnings in the summary and OUT/calibration/ (summary.json, report.html) beside the scan's
    // report, since a scan is only as good as the calibration it was measured with.
    if (cal.folder || cal.projector_folder) {
      const calib::CalibrationDiagnosis diagnosis =
          cal.folder ? calib::DiagnoseFolderCalibration(*cal.folder, cal.target)
                     : calib::DiagnoseProjectorCalibration(*cal.projector_folder, cal.target);
      s.calibration_warnings = diagnosis.diagnostics.warnings;
      for (const std::string& w : s.calibration_warnings) {
        util::LogWarning("scan: calibration: " + w);
      }
      if (options.write_report) {
        WriteOutput("calibration report", out, [&] {
          calib::WriteCalibrationReport(result.CalibrationDir(), diagnosis,
                                        cal.folder ? calib::CalibrationToJson(*cal.folder)
                                                   : CalibrationToJson(*cal.projector_folder));
        });
        s.calibration_report = "calibration/report.html";
      }
    }
    s.calibrate_s = timer.ElapsedSeconds();
    s.calibrate_cpu_s = cpu.ElapsedSeconds();

    // 2. Views, streamed: a serial source hands out view indices, at most views_in_flight are
    // read and reconstructed at once, results are stored by index (order-independent).
    util::Timer total;
    util::CpuTimer total_cpu;
    timer.Restart();
    cpu.Restart();
    // Stereo matching of the two cameras, or one camera against the projector's columns.
    const stereo::ViewReconstructor reconstructor =
        folder.stereo() ? stereo::ViewReconstructor(cal.rig, scheme, options.reconstruction)
                        : stereo::MakeCameraProjectorReconstructor(
                              stereo::CameraProjectorRig::FromLeftCamera(cal.rig), schemes,
                              options.reconstruction);
    const bool check_columns = folder.stereo() && !cal.rig.projector &&
                               options.fit_projector_columns &&
                               options.reconstruction.matching.max_projector_error_px > 0;
    std::vector<ViewResult> results(names.size());
    // Each finished view is kept in dir/.resume (view_checkpoint.h) until OUT is committed; with
    // --resume, the views an interrupted run of the same inputs and options finished are taken
    // from there instead of being decoded again.
    std::string rig_and_schemes = io::RigToJson(cal.rig).dump();
    for (const phase::PatternScheme& sc : schemes)
      rig_and_schemes += phase::SchemeToJson(sc).dump();
    rig_and_schemes += StrCat(" check_columns ", check_columns);
    std::atomic<int> resumed{0};
    std::atomic<int64_t> checkpoint_ns{0}, checkpoint_bytes{0};
    {
      util::Progress progress("scan: reconstruct views", static_cast<int>(names.size()));
      size_t next = 0;
      tbb::parallel_pipeline(
          static_cast<size_t>(s.views_in_flight),
          tbb::make_filter<void, size_t>(tbb::filter_mode::serial_in_order,
                                         [&](tbb::flow_control& fc) -> size_t {
                                           if (next == names.size()) {
                                             fc.stop();
                                             return 0;
                                           }
                                           return next++;
                                         }) &
              tbb::make_filter<size_t, void>(tbb::filter_mode::parallel, [&](size_t i) {
                const std::string key =
                    ViewCheckpointKey(folder, names[i], rig_and_schemes, options.resume_key);
                std::optional<ViewResult> kept;
                if (options.resume) kept = ReadViewCheckpoint(dir, names[i], key);
                if (kept) {
                  results[i] = std::move(*kept);
                  ++resumed;
                  // The view's files, as ProcessView writes them.
                  if (options.detect_markers) {
                    registration::WriteViewMarkers(result.ViewMarkers(names[i]),
                                                   results[i].markers);
                  }
                  if (!check_columns) WriteViewCloud(dir, &results[i]);
                } else {
                  results[i] = ProcessView(folder, names[i], schemes, cal.rig, reconstructor,
                                           options, check_columns, dir);
                  // A cache: when it cannot be kept (a full disk) the scan goes on without it,
                  // and the output's own writes report the disk.
                  if (results[i].summary.ok) {
                    try {
                      const util::Timer write_timer;
                      checkpoint_bytes +=
                          static_cast<int64_t>(WriteViewCheckpoint(dir, key, results[i]));
                      checkpoint_ns += static_cast<int64_t>(write_timer.ElapsedSeconds() * 1e9);
                    } catch (const std::exception& e) {
                      util::LogWarning(
                          StrCat("scan: view ", names[i], " not kept for --resume: ", e.what()));
                    }
                  }
                }
                progress.Advance();
              }));
    }
    s.views_resumed = resumed;
    s.checkpoint_s = static_cast<double>(checkpoint_ns.load()) * 1e-9;
    s.checkpoint_mib = static_cast<double>(checkpoint_bytes.load()) / (1024.0 * 1024.0);
    if (resumed > 0) {
      util::LogInfo(StrCat("scan: ", resumed.load(), " of ", names.size(),
                           " views taken from the interrupted run"));
    }
    if (check_columns) {
      CheckProjectorColumns(options, &results, &s);
      tbb::parallel_for(size_t{0}, results.size(),
                        [&](size_t i) { WriteViewCloud(dir, &results[i]); });
    }
    if (options.check_drift) CheckDrift(folder, schemes.size(), cal.rig, options, &results, &s);
    s.views_s = timer.ElapsedSeconds();
    s.views_cpu_s = cpu.ElapsedSeconds();
    for (const ViewResult& v : results) {
      s.views.push_back(v.summary);
      s.read_s += v.summary.read_s;
      s.decode_s += v.summary.decode_s;
      s.reconstruct_s += v.summary.reconstruct_s;
      s.markers_s += v.summary.markers_s;
    }
    HandleFailures(project, out, options.keep_going, &s);

    // 3. Registration of the views that worked.
    util::Progress progress("scan: register, fuse, mesh", 3);
    timer.Restart();
    cpu.Restart();
    Model m;
    for (size_t i = 0; i < results.size(); ++i) {
      if (!results[i].summary.ok) continue;
      m.view_of.push_back(static_cast<int>(i));
      m.grid_valid.push_back(results[i].cloud.valid);
      m.grid_size.emplace_back(results[i].cloud.width, results[i].cloud.height);
    }
    // Fusion at once, or in tiles streamed from OUT/views/ when the views' grids and fusion's
    // working memory would not fit in the limit beside the compact copies registration holds
    // (decided before registration, so that the grids need not be held through it when tiled).
    constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;
    int64_t ok_points = 0;
    double compact_bytes = 0;
    for (int i : m.view_of) {
      const OrganizedPointCloud& g = results[static_cast<size_t>(i)].cloud;
      const double n = static_cast<double>(g.NumValid());
      ok_points += static_cast<int64_t>(n);
      // What CompactGeometry copies per point, and the grid's slot.
      compact_bytes +=
          n * double(sizeof(uint32_t) + sizeof(Eigen::Vector3d) * (1 + g.cloud.has_normals()));
    }
    const double whole_gib = util::CurrentMemoryGiB() +
                             (compact_bytes + kFusionBytesPerPoint * double(ok_points)) / kGiB;
    const bool tiled = options.fusion_tile_mm > 0 || whole_gib > s.memory_limit_gib;
    // The views' compact clouds and grids (a copy of the cloud and a projection fit per view,
    // counted in register_s), one view per task: they are independent. Tiled, each view's grid is
    // dropped once copied (it is on disk, OUT/views/; fusion and registered/ read it from there).
    m.inputs.resize(m.view_of.size());
    std::vector<double> grid_spacing_mm(m.view_of.size(), 0.0);
    tbb::parallel_for(size_t{0}, m.inputs.size(), [&](size_t k) {
      ViewResult& v = results[static_cast<size_t>(m.view_of[k])];
      registration::RegistrationView& rv = m.inputs[k];
      rv.name = names[static_cast<size_t>(m.view_of[k])];
      rv.cloud = CompactGeometry(v.cloud);
      rv.grid = registration::IndexViewGrid(v.cloud);  // projective ICP association
      rv.markers = v.markers;
      if (!tiled) return;
      grid_spacing_mm[k] = fusion::GridSpacingMm(v.cloud);
      v.cloud = OrganizedPointCloud();
      v.phase_left.release();
    });
    if (tiled) util::ReleaseFreeMemory();
    m.registration = registration::RegisterViews(m.inputs, options.registration);
    const registration::RegistrationSummary& rs = m.registration.summary;
    s.registration_status = registration::ToString(rs.status);
    s.registration = registration::ToJson(m.registration);
    s.marker_adjusted_rms_mm = rs.adjustment.rms_final_mm;
    if (!rs.icp.levels.empty()) s.icp_rms_mm = rs.icp.levels.back().rms_end_mm;
    for (size_t k = 0; k < m.inputs.size(); ++k) {
      const registration::ViewRegistration& r = m.registration.views[k];
      ScanViewSummary& vs = s.views[static_cast<size_t>(m.view_of[k])];
      vs.registration_path = registration::ToString(r.path);
      vs.matched_markers = r.matched_markers;
      vs.marker_rms_mm = r.marker_rms_mm;
      vs.adjusted_rms_mm = r.adjusted_rms_mm;
      vs.overlap_fraction = r.overlap_fraction;
      if (r.placed()) continue;
      vs.ok = false;
      vs.failed_stage = "register";
      vs.message = StrCat("could not be registered (", registration::ToString(r.path),
                          "): ", r.message, "; ", vs.markers, " markers measured in the view, ",
                          r.matched_markers, " matched to the marker map");
    }
    HandleFailures(project, out, options.keep_going, &s);
    std::vector<std::string> placed_names;
    std::vector<Rigid3d> placed_poses;
    m.fusion_of.assign(m.inputs.size(), -1);
    std::vector<size_t> placed;  // registration inputs, in fusion order
    int64_t placed_points = 0;
    for (size_t k = 0; k < m.inputs.size(); ++k) {
      const registration::ViewRegistration& r = m.registration.views[k];
      if (!r.placed()) continue;
      placed_names.push_back(r.name);
      placed_poses.push_back(r.world_from_sensor);
      m.fusion_of[k] = static_cast<int>(placed.size());
      placed.push_back(k);
      placed_points += static_cast<int64_t>(m.inputs[k].cloud.size());
    }
    std::vector<fusion::FusionView> fusion_views;
    std::vector<fusion::TiledView> tiled_views;
    std::vector<Eigen::Vector3d> samples;  // every kSampleStride-th point, world frame
    constexpr size_t kSampleStride = 16;
    for (size_t k : placed) {
      const registration::ViewRegistration& r = m.registration.views[k];
      ViewResult& v = results[static_cast<size_t>(m.view_of[k])];
      if (!tiled) {
        fusion_views.push_back({r.name, std::move(v.cloud), r.world_from_sensor});
        continue;
      }
      const fs::path file = result.ViewCloud(r.name);
      const PointCloud& compact = m.inputs[k].cloud;
      tiled_views.push_back(fusion::DescribeTiledView(
          r.name, m.grid_size[k].width, m.grid_size[k].height, grid_spacing_mm[k], compact,
          r.world_from_sensor, [file] { return io::ReadOrganizedPly(file); }));
      for (size_t i = 0; i < compact.size(); i += kSampleStride)
        samples.push_back(r.world_from_sensor * compact.points[i]);
    }
    WriteOutput("register", out, [&] {
      registration::WritePoses(result.Poses(), placed_names, placed_poses);
      registration::WriteMarkerMap(result.MarkerMap(), m.registration, m.inputs);
    });
    s.register_s = timer.ElapsedSeconds();
    s.register_cpu_s = cpu.ElapsedSeconds();
    progress.Advance();

    // 4. Fusion and mesh.
    timer.Restart();
    cpu.Restart();
    fusion::FusionOptions fusion_options = options.fusion;
    fusion_options.registration_rms_mm =
        s.icp_rms_mm > 0 ? s.icp_rms_mm : std::max(s.marker_adjusted_rms_mm, 0.0);
    // A whole-scan stage without a usable result ends the scan with nothing written.
    const auto stage_failed = [&](const char* stage, const char* status,
                                  const std::string& message) {
      return Error(StrCat("scan: ", project.string(), ": stage '", stage, "' failed: ", status,
                          ": ", message, "; nothing was written to ", out.string()));
    };
    if (!tiled) {
      m.fused = fusion::FuseViews(fusion_views, fusion_options);
    } else {
      util::ReleaseFreeMemory();
      fusion::TileOptions tile_options;
      tile_options.scratch_dir = dir / ".fusion_tiles";
      const double margin_mm = fusion::TileMarginMm(tiled_views, fusion_options, tile_options);
      // Beside what is held: one full view being cut, and the fused output (~a quarter of the
      // input points, ~70 bytes each with support and view).
      int64_t largest_grid = 0;
      for (const fusion::TiledView& v : tiled_views)
        largest_grid = std::max(largest_grid, int64_t{v.width} * v.height);
      const double in_use_gib = util::CurrentMemoryGiB();
      const double free_bytes = (s.memory_limit_gib - in_use_gib) * kGiB -
                                kGridBytesPerSlot * double(largest_grid) -
                                0.25 * 70 * double(placed_points);
      const double max_points = std::max(0.0, free_bytes / kFusionBytesPerPoint);
      double tile_points = 0;
      tile_options.tile_size_mm = options.fusion_tile_mm > 0
                                      ? options.fusion_tile_mm
                                      : ChooseTileSize(samples, double(kSampleStride), margin_mm,
                                                       max_points, margin_mm, &tile_points);
      if (tile_options.tile_size_mm == 0) {
        throw Error(StrCat(
            "scan: ", project.string(), ": the memory limit of ", Fixed(s.memory_limit_gib, 3),
            " GiB (--memory-limit) is too small to fuse the ", placed.size(),
            " views: the smallest tile (", Fixed(margin_mm, 1), " mm with a margin of ",
            Fixed(margin_mm, 1), " mm) holds ~", static_cast<int64_t>(tile_points), " points, ~",
            Fixed(tile_points * kFusionBytesPerPoint / kGiB, 3), " GiB to fuse, beside ",
            Fixed(in_use_gib, 3),
            " GiB in use (registration holds every view's points); nothing was written to ",
            out.string()));
      }
      fusion::TiledFusionResult t = fusion::FuseTiled(tiled_views, fusion_options, tile_options);
      s.fusion_tiles = t.tiles.tiles_fused;
      s.fusion_tile_mm = t.tiles.tile_size_mm;
      s.tiling = ToJson(t.tiles);
      m.fused = std::move(t.result);
    }
    const fusion::FusionSummary& fs_ = m.fused.summary;
    s.fusion = fusion::ToJson(fs_);
    s.fusion["registration_rms_mm"] = fusion_options.registration_rms_mm;
    if (tiled) s.fusion["tiles"] = s.tiling;
    if (!fs_.has_output()) throw stage_failed("fuse", fusion::ToString(fs_.status), fs_.message);
    s.fused_points = fs_.fused_points;
    s.overlap_points = fs_.overlap_points;
    s.clusters = fs_.clusters;
    s.fuse_s = timer.ElapsedSeconds();
    s.fuse_cpu_s = cpu.ElapsedSeconds();
    progress.Advance();

    // Poisson runs on one thread (Open3D's OpenMP threads give other vertices from run to run,
    // docs/benchmarks.md), so the files that need no mesh are written meanwhile on the other
    // cores: fused.ply, and registered/ (the organized clouds moved into the world, so that
    // `fringe fuse OUT` can re-run fusion from OUT/poses.json and OUT/registered/; one view per
    // task), and the report's residuals are computed. mesh_s is the wall time of all together.
    // The report's residuals (before and after ICP), marker residuals and display frame.
    const auto report_residuals = [&] {
      std::vector<const PointCloud*> placed_clouds;
      std::vector<Rigid3d> adjusted, final_poses;
      for (size_t k = 0; k < m.inputs.size(); ++k) {
        const registration::ViewRegistration& r = m.registration.views[k];
        if (!r.placed()) continue;
        placed_clouds.push_back(&m.inputs[k].cloud);
        adjusted.push_back(r.path == registration::ViewPath::kMarkers ||
                                   r.path == registration::ViewPath::kWorld
                               ? r.world_from_sensor_adjusted
                               : r.world_from_sensor);
        final_poses.push_back(r.world_from_sensor);
        for (const registration::MapMarker& mk : m.registration.map) {
          for (const auto& sighting : mk.sightings) {
            if (static_cast<size_t>(sighting.view) != k) continue;
            const auto& vm = m.inputs[k].markers[static_cast<size_t>(sighting.view_marker)];
            m.marker_residuals_mm.push_back(
                (r.world_from_sensor * vm.centre_in_sensor - mk.centre_in_world).norm());
          }
        }
      }
      m.display_from_world = DisplayFromViews(final_poses);
      if (options.write_report) {
        m.residual_threshold_mm =
            rs.icp.levels.empty() ? 1.0 : std::max(rs.icp.levels.front().threshold_start_mm, 0.05);
        m.residuals_adjusted_mm =
            OverlapResiduals(placed_clouds, adjusted, m.residual_threshold_mm);
        m.residuals_final_mm =
            OverlapResiduals(placed_clouds, final_poses, m.residual_threshold_mm);
      }
    };
    timer.Restart();
    cpu.Restart();
    {
      tbb::task_group meshing;
      meshing.run([&] {
        m.mesh = fusion::MeshPoisson(m.fused.fused, options.mesh);
        if (!m.mesh.summary.ok()) return;
        WriteOutput("mesh", out, [&] {
          tbb::parallel_invoke([&] { fusion::WriteMeshFile(result.Mesh(), m.mesh); },
                               [&] { fusion::WriteMeshFile(result.MeshStl(), m.mesh); });
        });
      });
      std::exception_ptr failure;
      try {
        WriteOutput("fuse", out, [&] {
          io::WritePly(result.Fused(), m.fused.fused, io::PlyFormat::kBinaryLittleEndian,
                       {"fringe scan: fused views, world frame (the first view's sensor frame), "
                        "mm; intensity = texture, quality = weighted modulation"});
        });
        fs::create_directories(result.RegisteredDir());
        // Tiled: the grids are read back from OUT/views/ one view per task.
        tbb::parallel_for(size_t{0}, placed.size(), [&](size_t f) {
          const std::string& name = placed_names[f];
          OrganizedPointCloud world =
              tiled ? io::ReadOrganizedPly(result.ViewCloud(name)) : fusion_views[f].cloud;
          registration::TransformGrid(placed_poses[f], &world);
          WriteOutput("register", out, [&] {
            io::WritePly(result.RegisteredCloud(name), world, io::PlyFormat::kBinaryLittleEndian,
                         {StrCat("fringe scan: view ", name,
                                 " registered, world frame (the first view's sensor frame), mm")});
          });
        });
        report_residuals();
      } catch (...) {
        failure = std::current_exception();
      }
      meshing.wait();  // rethrows the meshing's exception
      if (failure) std::rethrow_exception(failure);
    }
    fusion_views.clear();  // the grids are no longer needed
    const fusion::MeshSummary& ms = m.mesh.summary;
    s.meshing = fusion::ToJson(ms);
    if (!ms.ok()) throw stage_failed("mesh", fusion::ToString(ms.status), ms.message);
    s.mesh_vertices = ms.vertices;
    s.mesh_triangles = ms.triangles;
    s.mesh_watertight = ms.watertight;
    s.mesh_s = timer.ElapsedSeconds();
    s.mesh_cpu_s = cpu.ElapsedSeconds();
    progress.Advance();

    s.total_s = total.ElapsedSeconds();
    s.total_cpu_s = total_cpu.ElapsedSeconds();
    // 5. Truth (simulated scans): not part of a real scan, timed apart.
    if (options.evaluate_truth && folder.has_truth()) {
      timer.Restart();
      cpu.Restart();
      s.has_truth = true;
      EvaluateAgainstTruth(folder, &m, &s);
      // The colour ranges: the tolerance given, else from the data; the views' maps share one
      // range (all their values together) so that the views compare.
      const auto deviation_range = [&](const std::vector<double>& values) {
        return options.tolerance_mm > 0 ? io::DeviationRange::FromTolerance(options.tolerance_mm)
                                        : io::DeviationRange::FromData(values);
      };
      m.mesh_deviation_range = deviation_range(m.mesh_deviation_mm);
      std::vector<double> view_values;
      for (const cv::Mat& map : m.view_deviation_mm) {
        if (!map.empty())
          view_values.insert(view_values.end(), map.begin<float>(), map.end<float>());
      }
      const io::DeviationRange view_range = deviation_range(view_values);
      for (size_t k = 0; k < m.view_deviation_mm.size(); ++k) {
        if (m.view_deviation_mm[k].empty()) continue;
        const size_t i = static_cast<size_t>(m.view_of[k]);
        results[i].pictures.push_back(
            {StrCat("view ", s.views[i].name,
                    ": signed deviation from the truth of the view's points placed by their TRUE "
                    "pose (the sensor alone, registration excluded), mm; RMS ",
                    Fixed(s.views[i].truth_rms_mm, 4), " mm; dark grey: no point"),
             ColourMapWithBar(m.view_deviation_mm[k], view_range.lo(), view_range.hi(),
                              view_range.Legend("signed deviation from truth, mm"),
                              kPictureWidthPx)});
      }
      s.evaluate_s = timer.ElapsedSeconds();
      s.evaluate_cpu_s = cpu.ElapsedSeconds();
    }

    // 6. Summary and report.
    s.peak_mem_gib = util::PeakMemoryGiB();
    if (options.write_report) {
      timer.Restart();
      cpu.Restart();
      const Report report = BuildReport(project, s, cal, results, m);
      WriteOutput("report", out, [&] { report.Write(result.Report()); });
      const double report_s = timer.ElapsedSeconds(), report_cpu_s = cpu.ElapsedSeconds();
      s.report_s += report_s;
      s.report_cpu_s += report_cpu_s;
      s.total_s += report_s;
      s.total_cpu_s += report_cpu_s;
    }
    WriteOutput("summary", out, [&] { io::WriteJson(result.Summary(), ToJson(s)); });
    // The views' checkpoints are a cache of this run, not an output.
    std::error_code ec;
    fs::remove_all(dir / kCheckpointFolder, ec);
  });
  return s;
}

}  // namespace fringe::pipeline
