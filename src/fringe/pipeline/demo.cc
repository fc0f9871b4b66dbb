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

std::string Figure(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream os;
  os << std::fixed << std::setprecision(digits) << v;
  return os.str();
}

}  // namespace

void DemoOptions::Check() const {
  util::CheckOption(views >= 2 && views <= 64, "DemoOptions", "views", views,
                    "must be in [2, 64] (registration needs several views)");
  util::CheckOption(rig_scale > 0.25 && rig_scale <= 1, "DemoOptions", "rig_scale", rig_scale,
                    "must be in (0.25, 1]: below half size the 5 mm markers are too small");
  util::CheckOption(calibration_images >= 6, "DemoOptions", "calibration_images",
                    calibration_images, "must be >= 6 (Zhang needs several board poses)");
  phase::MakeScheme(scheme);  // throws for an unknown preset
  scan.Check();
}

std::string DemoSummary::Report() const {
  const ScanSummary& s = scan;
  std::ostringstream os;
  os << std::fixed;
  os << "demo part: " << views << " views, " << image_width << " x " << image_height
     << " px cameras (rig scale " << std::setprecision(2) << rig_scale << "), " << s.views_ok
     << " measured, " << s.points << " points, " << s.fused_points << " fused points, mesh "
     << s.mesh_triangles << " triangles\n";
  os << "calibration (from simulated board images, against the true rig)\n"
     << std::setprecision(3) << "  RMS reprojection      left " << calibration_rms_left_px
     << " px, right " << calibration_rms_right_px << " px\n"
     << std::setprecision(4) << "  focal length error    " << focal_error_pct << " %\n"
     << "  baseline error        " << baseline_error_mm << " mm\n";
  os << "registration and fusion (against the truth)\n"
     << "  pose error (max)      " << Figure(s.pose_rot_err_deg, 4) << " deg, "
     << Figure(s.pose_trans_err_mm, 4) << " mm\n"
     << "  single-view RMS       " << Figure(s.single_view_rms_mm, 4)
     << " mm (overlaps; all points " << Figure(s.single_view_all_rms_mm, 4) << " mm)\n"
     << "  fused RMS             " << Figure(s.fused_rms_mm, 4) << " mm (merged points "
     << Figure(s.fused_overlap_rms_mm, 4) << " mm)\n"
     << "  mesh RMS              " << Figure(s.mesh_rms_mm, 4) << " mm\n";
  os << "VDI/VDE 2634-2 artefacts\n";
  auto fig = [&](const char* name, bool ok, double v) {
    os << "  " << name << (ok ? Figure(v, 4) + " mm\n" : std::string("not measured\n"));
  };
  fig("PF (sphere form)      ", sphere_ok, PF_mm);
  fig("PS (sphere size)      ", sphere_ok, PS_mm);
  fig("SD (ball bar)         ", ballbar_ok, SD_mm);
  fig("F  (flatness)         ", plane_ok, F_mm);
  os << std::setprecision(1) << "time, s: simulate " << simulate_s << ", calibrate "
     << s.calibrate_s << ", scan " << s.total_s << " (views " << s.views_s << ", register "
     << s.register_s << ", fuse " << s.fuse_s << ", mesh " << s.mesh_s << ", report " << s.report_s
     << "), truth comparison " << s.evaluate_s << ", VDI artefacts " << vdi_s << "; whole demo "
     << total_s << "\n";
  return os.str();
}

json ToJson(const DemoSummary& s) {
  json j = FiguresJson(s.scan);
  j["views"] = s.views;
  j["rig_scale"] = s.rig_scale;
  j["image_width"] = s.image_width;
  j["image_height"] = s.image_height;
  j["simulate_s"] = s.simulate_s;
  j["vdi_s"] = s.vdi_s;
  j["demo_s"] = s.total_s;
  j["calibration_rms_left_px"] = s.calibration_rms_left_px;
  j["calibration_rms_right_px"] = s.calibration_rms_right_px;
  j["focal_error_pct"] = s.focal_error_pct;
  j["baseline_error_mm"] = s.baseline_error_mm;
  j["PF_mm"] = s.sphere_ok ? json(s.PF_mm) : json(nullptr);
  j["PS_mm"] = s.sphere_ok ? json(s.PS_mm) : json(nullptr);
  j["SD_mm"] = s.ballbar_ok ? json(s.SD_mm) : json(nullptr);
  j["F_mm"] = s.plane_ok ? json(s.F_mm) : json(nullptr);
  return j;
}

DemoSummary RunDemo(const DemoOptions& options, const fs::path& out_dir) {
  options.Check();
  DemoSummary s;
  const StereoRig true_rig = sim::ScaledRig(StereoRig::Reference(), options.rig_scale);
  s.views = options.views;
  s.rig_scale = options.rig_scale;
  s.image_width = true_rig.left.width;
  s.image_height = true_rig.left.height;
  // A demo folder written before output folders carried the marker is recognised by its layout,
  // so that re-running the README's demo command replaces it.
  util::OutputFolderOptions output;
  output.legacy_layout = [](const fs::path& d) {
    return fs::is_directory(d / "scan-demo") && fs::is_directory(d / "scan-vdi") &&
           fs::exists(d / "calibration.json");
  };
  util::Timer demo_timer;
  util::WriteFolderAtomically(out_dir, output, [&](const fs::path& dir) {
    // 1. Simulate.
    util::Timer timer;
    sim::ScanOptions demo_scan;
    demo_scan.scene = "demo";
    demo_scan.views = options.views;
    demo_scan.seed = options.seed;
    demo_scan.scheme =
        phase::MakeScheme(options.scheme, true_rig.projector->width, true_rig.projector->height);
    demo_scan.scheme->gamma_precompensation = demo_scan.render.projector.gamma;
    demo_scan.calibration_images = options.calibration_images;
    demo_scan.truth_maps = false;  // the scan compares with the truth mesh and poses
    util::LogInfo(StrCat("simulating ", options.views, " views of the demo part and ",
                         options.calibration_images, " calibration board poses"));
    sim::SimulateScan(true_rig, demo_scan, dir / "scan-demo");
    sim::ScanOptions vdi = demo_scan;
    vdi.scene = "vdi";
    vdi.views = 1;
    vdi.calibration_images = 0;
    util::LogInfo("simulating the VDI/VDE 2634-2 artefacts");
    sim::SimulateScan(true_rig, vdi, dir / "scan-vdi");
    s.simulate_s = timer.ElapsedSeconds();

    // 2. The scanner on the demo part: it calibrates from the board images itself.
    ScanOptions scan_options = options.scan;
    if (options.use_true_calibration) scan_options.calib = dir / "scan-demo" / "truth" / "rig.json";
    s.scan = RunScan(dir / "scan-demo", dir / "scan", scan_options);
    const StereoRig est = io::ReadRig(dir / "scan" / "rig.json");
    s.calibration_rms_left_px = s.scan.calibration_rms_left_px;
    s.calibration_rms_right_px = s.scan.calibration_rms_right_px;
    for (const auto& [e, t] :
         {std::make_pair(est.left, true_rig.left), std::make_pair(est.right, true_rig.right)}) {
      s.focal_error_pct = std::max({s.focal_error_pct, 100 * std::abs(e.fx - t.fx) / t.fx,
                                    100 * std::abs(e.fy - t.fy) / t.fy});
    }
    s.baseline_error_mm = std::abs(est.BaselineMm() - true_rig.BaselineMm());

    // 3. The VDI/VDE 2634-2 artefacts, measured with the same (calibrated) rig.
    timer.Restart();
    util::LogInfo("measuring the VDI/VDE 2634-2 artefacts");
    const scan::ScanFolder scan_vdi = scan::ScanFolder::Open(dir / "scan-vdi");
    const stereo::ViewReconstruction artefacts = ReconstructScanView(est, scan_vdi, "000");
    io::WritePly(dir / "vdi_artefacts.ply", artefacts.cloud);
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
    s.vdi_s = timer.ElapsedSeconds();
    s.total_s = demo_timer.ElapsedSeconds();
    io::WriteJson(dir / "report.json", ToJson(s));
    {
      std::ofstream text(dir / "report.txt");
      text << s.Report();
      util::CloseOutput(text, dir / "report.txt");
    }
  });
  return s;
}

}  // namespace fringe::pipeline
