#include "fringe/pipeline/demo.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>

#include "fringe/calib/calibrate_folder.h"
#include "fringe/eval/deviation.h"
#include "fringe/eval/vdi2634.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/mesh_io.h"
#include "fringe/io/ply.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/sim/scan.h"
#include "fringe/stereo/reconstruct_view.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/log.h"
#include "fringe/util/timer.h"

namespace fringe::pipeline {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using util::StrCat;

// Deviation colour map range: the demo part's expected errors are tens of micrometres.
constexpr double kDeviationRangeMm = 0.1;

stereo::ViewReconstruction ReconstructScanView(const StereoRig& rig, const scan::ScanFolder& folder,
                                               const std::string& view) {
  const phase::PatternScheme scheme = folder.ReadScheme();
  const auto left = folder.ReadStack(view, scan::Camera::kLeft, scheme);
  const auto right = folder.ReadStack(view, scan::Camera::kRight, scheme);
  stereo::ViewReconstruction rec = stereo::ReconstructView(rig, scheme, left, right);
  if (!rec.summary.ok()) {
    throw Error(StrCat(folder.root().string(), ": view ", view,
                       " did not reconstruct: ", rec.summary.message));
  }
  return rec;
}

PointCloud Transformed(const PointCloud& cloud, const Rigid3d& b_from_a) {
  PointCloud out = cloud;
  for (auto& p : out.points) p = b_from_a * p;
  for (auto& n : out.normals) n = b_from_a.RotateDirection(n);
  return out;
}

}  // namespace

void DemoOptions::Check() const {
  util::CheckOption(calibration_images >= 6, "DemoOptions", "calibration_images",
                    calibration_images, "must be >= 6 (Zhang needs several board poses)");
  util::CheckOption(precompensate_gamma > 0 && precompensate_gamma <= 10, "DemoOptions",
                    "precompensate_gamma", precompensate_gamma, "must be in (0, 10]");
  phase::MakeScheme(scheme);  // throws for an unknown preset
}

std::string DemoSummary::Report() const {
  std::ostringstream os;
  os << std::fixed;
  os << "calibration (estimated from simulated board images, against the true rig)\n"
     << std::setprecision(3) << "  RMS reprojection   left " << calibration_rms_left_px
     << " px, right " << calibration_rms_right_px << " px\n"
     << std::setprecision(4) << "  focal length error " << focal_error_pct << " %\n"
     << "  baseline error     " << baseline_error_mm << " mm\n";
  os << "demo part (view 000, against the truth mesh)\n"
     << "  points             " << part_points << ", coverage " << std::setprecision(1)
     << 100.0 * part_coverage << " %\n"
     << std::setprecision(4) << "  deviation          mean " << part_mean_mm << " mm, RMS "
     << part_rms_mm << " mm, 95 % " << part_p95_mm << " mm, max " << part_max_mm << " mm\n";
  os << "VDI/VDE 2634-2 artefacts\n";
  auto fig = [&](const char* name, bool ok, double v) {
    os << "  " << name;
    if (ok) {
      os << std::setprecision(4) << v << " mm\n";
    } else {
      os << "not measured\n";
    }
  };
  fig("PF (sphere form)   ", sphere_ok, PF_mm);
  fig("PS (sphere size)   ", sphere_ok, PS_mm);
  fig("SD (ball bar)      ", ballbar_ok, SD_mm);
  fig("F  (flatness)      ", plane_ok, F_mm);
  os << std::setprecision(1) << "time: simulate " << seconds_simulate << " s, calibrate "
     << seconds_calibrate << " s, reconstruct " << seconds_reconstruct << " s, evaluate "
     << seconds_evaluate << " s\n";
  return os.str();
}

json DemoSummary::ToJson() const {
  json j{{"calibration_rms_left_px", calibration_rms_left_px},
         {"calibration_rms_right_px", calibration_rms_right_px},
         {"focal_error_pct", focal_error_pct},
         {"baseline_error_mm", baseline_error_mm},
         {"part_points", part_points},
         {"part_coverage", part_coverage},
         {"part_mean_mm", part_mean_mm},
         {"part_rms_mm", part_rms_mm},
         {"part_p95_mm", part_p95_mm},
         {"part_max_mm", part_max_mm},
         {"seconds_simulate", seconds_simulate},
         {"seconds_calibrate", seconds_calibrate},
         {"seconds_reconstruct", seconds_reconstruct},
         {"seconds_evaluate", seconds_evaluate}};
  j["PF_mm"] = sphere_ok ? json(PF_mm) : json(nullptr);
  j["PS_mm"] = sphere_ok ? json(PS_mm) : json(nullptr);
  j["SD_mm"] = ballbar_ok ? json(SD_mm) : json(nullptr);
  j["F_mm"] = plane_ok ? json(F_mm) : json(nullptr);
  return j;
}

DemoSummary RunDemo(const DemoOptions& options, const fs::path& out_dir) {
  options.Check();
  DemoSummary s;
  const StereoRig true_rig = StereoRig::Reference();
  // A demo folder written before output folders carried the marker is recognised by its layout,
  // so that re-running the README's demo command replaces it.
  util::OutputFolderOptions output;
  output.legacy_layout = [](const fs::path& d) {
    return fs::is_directory(d / "scan-demo") && fs::is_directory(d / "scan-vdi") &&
           fs::exists(d / "calibration.json");
  };
  util::WriteFolderAtomically(out_dir, output, [&](const fs::path& dir) {
    // 1. Simulate.
    util::Timer timer;
    sim::ScanOptions demo_scan;
    demo_scan.scene = "demo";
    demo_scan.views = 1;
    demo_scan.seed = options.seed;
    demo_scan.scheme = options.scheme;
    demo_scan.precompensate_gamma = options.precompensate_gamma;
    demo_scan.calibration_images = options.calibration_images;
    util::LogInfo("simulating the demo part and " + std::to_string(options.calibration_images) +
                  " calibration board poses");
    sim::SimulateScan(true_rig, demo_scan, dir / "scan-demo");
    sim::ScanOptions vdi = demo_scan;
    vdi.scene = "vdi";
    vdi.calibration_images = 0;
    util::LogInfo("simulating the VDI/VDE 2634-2 artefacts");
    sim::SimulateScan(true_rig, vdi, dir / "scan-vdi");
    s.seconds_simulate = timer.ElapsedSeconds();

    // 2. Calibrate from the board images.
    timer.Restart();
    util::LogInfo("calibrating from the board images");
    const scan::ScanFolder scan_demo = scan::ScanFolder::Open(dir / "scan-demo");
    const scan::ScanFolder scan_vdi = scan::ScanFolder::Open(dir / "scan-vdi");
    const calib::FolderCalibration cal =
        calib::CalibrateFolder(scan_demo.layout().CalibrationDir(), scan_demo.ReadTarget());
    if (!cal.success()) {
      throw Error(StrCat("demo: calibration failed: ", cal.pair.summary.message));
    }
    calib::WriteFolderCalibration(dir / "calibration.json", cal);
    io::WriteImage(dir / "calibration_residuals_left.png", calib::ResidualImage(cal.pair.left));
    s.calibration_rms_left_px = cal.pair.left.summary.final_rms_px;
    s.calibration_rms_right_px = cal.pair.right.summary.final_rms_px;
    const StereoRig& est = cal.pair.rig;
    for (const auto& [e, t] :
         {std::make_pair(est.left, true_rig.left), std::make_pair(est.right, true_rig.right)}) {
      s.focal_error_pct = std::max({s.focal_error_pct, 100 * std::abs(e.fx - t.fx) / t.fx,
                                    100 * std::abs(e.fy - t.fy) / t.fy});
    }
    s.baseline_error_mm = std::abs(est.BaselineMm() - true_rig.BaselineMm());
    s.seconds_calibrate = timer.ElapsedSeconds();
    const StereoRig& rig = options.use_true_calibration ? true_rig : est;

    // 3. Reconstruct.
    timer.Restart();
    util::LogInfo("reconstructing the demo part and the artefacts");
    const stereo::ViewReconstruction part = ReconstructScanView(rig, scan_demo, "000");
    io::WritePly(dir / "demo_part.ply", part.cloud);
    const stereo::ViewReconstruction artefacts = ReconstructScanView(rig, scan_vdi, "000");
    io::WritePly(dir / "vdi_artefacts.ply", artefacts.cloud);
    s.seconds_reconstruct = timer.ElapsedSeconds();

    // 4. Evaluate against the truth.
    timer.Restart();
    util::LogInfo("evaluating against the truth");
    {
      const Rigid3d world_from_sensor =
          scan_demo.ReadTruthPoses().Find("000")->world_from_sensor;  // checked by ReadTruthPoses
      const eval::MeshDistance distance(scan_demo.ReadTruthMesh());
      // Distances on the grid, for the picture.
      PointCloud grid_world = Transformed(part.cloud.cloud, world_from_sensor);
      std::vector<double> d_grid(part.cloud.valid.size(), std::numeric_limits<double>::quiet_NaN());
      PointCloud measured;
      std::vector<size_t> slot;
      for (size_t i = 0; i < part.cloud.valid.size(); ++i) {
        if (!part.cloud.valid[i]) continue;
        measured.points.push_back(grid_world.points[i]);
        slot.push_back(i);
      }
      std::vector<double> d;
      const eval::DeviationStats dev = eval::DeviationFromMesh(measured, distance, {}, &d);
      for (size_t k = 0; k < slot.size(); ++k) d_grid[slot[k]] = d[k];
      io::WriteImage(
          dir / "demo_part_deviation.png",
          eval::DeviationColorMap(part.cloud.width, part.cloud.height, d_grid, kDeviationRangeMm));
      s.part_points = static_cast<int>(measured.size());
      s.part_mean_mm = dev.mean_mm;
      s.part_rms_mm = dev.rms_mm;
      s.part_p95_mm = dev.p95_mm;
      s.part_max_mm = dev.max_mm;
      const cv::Mat valid =
          io::ReadGrayImage(scan_demo.layout().TruthMaps("000", scan::Camera::kLeft) / "valid.png");
      size_t seen = 0, measured_seen = 0;
      for (int r = 0; r < valid.rows; ++r) {
        for (int c = 0; c < valid.cols; ++c) {
          if (!valid.at<uint8_t>(r, c)) continue;
          ++seen;
          measured_seen += part.cloud.valid[part.cloud.index(c, r)] != 0;
        }
      }
      s.part_coverage = seen ? double(measured_seen) / seen : 0.0;
    }
    {
      const scan::TruthScene truth = scan_vdi.ReadTruthScene();
      auto sphere = [&](const char* name) -> const scan::TruthSphere* {
        const scan::TruthObject* o = truth.Find(name);
        return o && o->sphere ? &*o->sphere : nullptr;
      };
      const PointCloud cloud = artefacts.cloud.Compact();
      if (const scan::TruthSphere* truth_sphere = sphere("sphere")) {
        const eval::SphereResult r = eval::EvaluateSphere(cloud, 2 * truth_sphere->radius_mm);
        s.sphere_ok = r.ok();
        s.PF_mm = r.PF_mm;
        s.PS_mm = r.PS_mm;
      }
      if (sphere("sphere_a") && sphere("sphere_b")) {
        const scan::TruthSphere& a = *sphere("sphere_a");
        const scan::TruthSphere& b = *sphere("sphere_b");
        const eval::BallBarResult r = eval::EvaluateBallBar(
            cloud, 2 * a.radius_mm, (a.centre_in_world - b.centre_in_world).norm());
        s.ballbar_ok = r.ok();
        s.SD_mm = r.SD_mm;
      }
      const eval::PlaneResult plane = eval::EvaluatePlane(cloud);
      s.plane_ok = plane.ok();
      s.F_mm = plane.F_mm;
    }
    s.seconds_evaluate = timer.ElapsedSeconds();
    io::WriteJson(dir / "report.json", s.ToJson());
    std::ofstream(dir / "report.txt") << s.Report();
  });
  return s;
}

}  // namespace fringe::pipeline
