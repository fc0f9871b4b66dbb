// End to end: the demo's simulated measurement (the whole scanner) must meet the accuracy the
// issues ask of the chain (calibration from simulated boards, registration, fusion, VDI
// figures), judged against the simulator's exact truth. Scaled down for the test suite: 3 views
// on the half-size rig (the README's demo runs 8); the figures the issues set for the full-size
// rig are checked by bench_pipeline.
#include "fringe/pipeline/demo.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fringe/io/json.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::pipeline {
namespace {

constexpr double kMaxFocalErrorPct = 0.01;    // issue 5: focal error <= 0.01 %
constexpr double kMaxBaselineErrorMm = 0.01;  // issue 5: baseline error <= 0.01 mm
// Issue 6 asks PS and SD within +-0.02 mm on the full-size rig; the half-size rig has a quarter
// of the points on each sphere (PS -0.022 mm measured in the 8-view half-size demo).
constexpr double kMaxSizeErrorMm = 0.03;
constexpr double kMaxRotErrDeg = 0.03;  // registration with >= 20 shared markers + ICP
constexpr double kMaxTransErrMm = 0.03;
constexpr double kMaxFusedOverSingle = 0.8;  // merged points vs single views in the overlaps

TEST(Demo, WholeScannerMeetsAccuracyTargets) {
  test::TempDir dir;
  DemoOptions o;
  o.views = 3;
  o.rig_scale = 0.5;
  o.calibration_images = 10;
  o.scan.mesh.poisson_depth = 8;
  const DemoSummary s = RunDemo(o, dir / "demo");
  EXPECT_EQ(s.scan.views_ok, 3);
  EXPECT_LT(s.focal_error_pct, kMaxFocalErrorPct);
  EXPECT_LT(s.baseline_error_mm, kMaxBaselineErrorMm);
  EXPECT_LT(s.scan.pose_rot_err_deg, kMaxRotErrDeg);
  EXPECT_LT(s.scan.pose_trans_err_mm, kMaxTransErrMm);
  EXPECT_LT(s.scan.fused_overlap_rms_mm, kMaxFusedOverSingle * s.scan.single_view_rms_mm);
  ASSERT_TRUE(s.sphere_ok);
  ASSERT_TRUE(s.ballbar_ok);
  ASSERT_TRUE(s.plane_ok);
  EXPECT_LT(std::abs(s.PS_mm), kMaxSizeErrorMm);
  EXPECT_LT(std::abs(s.SD_mm), kMaxSizeErrorMm);
  for (const char* f : {"report.json", "report.txt", "vdi_artefacts.ply", "scan/report.html",
                        "scan/mesh.stl", "scan/fused.ply", "scan/poses.json",
                        "scan/calibration/report.html", "scan/calibration/summary.json"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / "demo" / f)) << f;
  }
  // The scan calibrated its rig from the board images: the calibration's own report is beside
  // the scan's, which points to it, and its diagnostics are those `fringe calibrate` writes.
  EXPECT_EQ(s.scan.calibration_report, "calibration/report.html");
  EXPECT_NE(
      util::ReadTextFile(dir / "demo" / "scan" / "report.html").find("calibration/report.html"),
      std::string::npos);
  const auto cal = io::ReadJson(dir / "demo" / "scan" / "calibration" / "summary.json");
  EXPECT_TRUE(cal.contains("calibration") && cal.contains("diagnostics"));
  const auto scan_summary = io::ReadJson(dir / "demo" / "scan" / "summary.json");
  EXPECT_EQ(scan_summary.at("calibration_report").get<std::string>(), "calibration/report.html");
  EXPECT_TRUE(scan_summary.at("calibration_warnings").is_array());
  // --json: every key the issue lists, as numbers.
  const auto j = io::ReadJson(dir / "demo" / "report.json");
  for (const char* key :
       {"views", "points", "simulate_s", "calibrate_s", "total_s", "read_s", "decode_s",
        "reconstruct_s", "register_s", "fuse_s", "mesh_s", "report_s", "peak_mem_gib",
        "pose_rot_err_deg", "pose_trans_err_mm", "fused_rms_mm", "single_view_rms_mm"}) {
    EXPECT_TRUE(j.contains(key) && j[key].is_number()) << key;
  }
}

TEST(Demo, BadOptionsAndUnwritableOutput) {
  DemoOptions o;
  EXPECT_NO_THROW(DemoOptions().Check());
  o.calibration_images = 2;
  EXPECT_THROW(o.Check(), Error);
  o = DemoOptions();
  o.views = 1;
  EXPECT_THROW(o.Check(), Error);
  o = DemoOptions();
  o.rig_scale = 0.25;  // markers too small to register by
  EXPECT_THROW(o.Check(), Error);
  o = DemoOptions();
  o.scheme = "no-such-scheme";
  EXPECT_THROW(o.Check(), Error);
  EXPECT_THROW(RunDemo(DemoOptions(), "/nonexistent/folder/demo"), Error);
}

}  // namespace
}  // namespace fringe::pipeline
