// End to end on a small simulated scan (half-size rig, 3 views of the demo part with its
// markers): reconstruction, registration, fusion and mesh against the simulator's truth, and
// failure injection (missing or truncated image, corrupt or wrong calibration, all markers
// removed from a view, unwritable output): each gives its clear error and leaves OUT without
// partial results, or with keep_going a complete result without the bad view.
//
// The half-size rig (640 x 512) is the smallest on which the demo's 5 mm markers are detected
// reliably (~12 px across); on the quarter-size rig they are ~6 px and registration has to fall
// back to marker-free alignment.
#include "fringe/pipeline/scan.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fringe/eval/deviation.h"
#include "fringe/geometry/point_index.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/mesh_io.h"
#include "fringe/io/ply.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/registration_io.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/scan/truth.h"
#include "fringe/sim/scan.h"
#include "fringe/testing/file_size_limit.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/testing/report.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::pipeline {
namespace {

namespace fs = std::filesystem;

// A view of the demo part on the half-size rig (~0.4 mm per pixel): noise and sampling make
// single points scatter ~0.06 mm; a view's RMS to the truth mesh stays well below this.
constexpr double kMaxViewRmsMm = 0.15;
constexpr double kMinValidFraction = 0.2;  // the part and its plate fill much of the image
// Registration with >= 20 shared markers and ICP on this rig: a few thousandths of a degree
// and of a millimetre (bench figures at full size are tighter).
constexpr double kMaxRotErrDeg = 0.03;
constexpr double kMaxTransErrMm = 0.03;
// Fusion: merged points lie closer to the truth than the single views in the same overlaps
// (issue 12's target, 0.8x); the whole fused cloud (with its unmerged borders) stays close.
constexpr double kFusedOverSingleOverlap = 0.8;
constexpr double kMaxFusedRmsMm = 0.15;
constexpr double kMaxMeshRmsMm = 0.15;
// Camera + projector: the projector sits midway between the cameras (half the stereo baseline,
// so about twice the depth noise) and markers are measured in one camera (ring centre ray
// against the fitted surface), so registration is looser than in stereo.
constexpr double kMaxTransErrMmCameraProjector = 0.1;
// Drift on the true rig: the markers' epipolar residual is their centres' noise (0.09-0.13 px
// RMS on this half-size rig, ~12 px markers), its systematic part (the fitted plane) a fraction
// of it (0.02-0.065 px), and the points' mean projector column residual nearly zero (0.002 px);
// inside DriftOptions' thresholds (0.1 px, 0.05 px), which the drifted rig below exceeds.
constexpr double kMaxIntactEpipolarRmsPx = 0.2;
constexpr double kMaxIntactSystematicPx = 0.08;
constexpr double kMaxIntactProjectorBiasPx = 0.02;

// Small, quick meshing for tests (the default depth 10 is for the full-size scan).
ScanOptions TestOptions() {
  ScanOptions o;
  o.mesh.poisson_depth = 8;
  return o;
}

// The fixtures' scans: the demo part on the half-size rig, 3 views, patterns pre-compensated
// for the projector's gamma, simulated into `dir` with `adjust` applied to the options first;
// rig.json is the true rig.
void SimulateHalfSizeDemoScan(const fs::path& dir,
                              const std::function<void(sim::ScanOptions*)>& adjust = {}) {
  sim::ScanOptions o;
  o.scene = "demo";
  o.views = 3;
  o.calibration_images = 0;
  o.render.sensor.supersampling = 1;
  o.truth_maps = false;
  const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.5);
  o.scheme = phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  o.scheme->gamma_precompensation = o.render.projector.gamma;
  if (adjust) adjust(&o);
  sim::SimulateScan(rig, o, dir);
  fs::copy_file(dir / "truth" / "rig.json", dir / "rig.json");
}

class ScanTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    SimulateHalfSizeDemoScan(*dir_ / "scan");
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  // A fresh copy of the simulated scan folder to damage.
  fs::path CopyOfScan(const std::string& name) const {
    const fs::path copy = tmp_ / name;
    fs::copy(*dir_ / "scan", copy, fs::copy_options::recursive);
    return copy;
  }
  static fs::path Scan() { return *dir_ / "scan"; }

  static test::TempDir* dir_;
  test::TempDir tmp_;
};
test::TempDir* ScanTest::dir_ = nullptr;

TEST(ScanOptions, DefaultsPassCheck) {
  EXPECT_NO_THROW(ScanOptions().Check());
  ScanOptions o;
  o.views_in_flight = 0;
  EXPECT_THROW(o.Check(), Error);
  o = ScanOptions();
  o.opencv_intrinsics = "a.yml";
  EXPECT_THROW(o.Check(), Error);  // extrinsics missing
}

// A stereo rig without a calibrated projector (what calibration from board images gives): the
// scanner fits the projector's columns to the scan's own points and drops the points off them,
// the check the matcher makes with a calibrated projector. The fit must agree with the true
// projector, and dropping the false matches must not make the fused cloud worse (on the
// full-size scan it halves its RMS).
TEST_F(ScanTest, ProjectorlessRigFitsTheProjectorColumnsFromTheScan) {
  constexpr double kMaxColumnRmsPx = 0.1;   // phase noise of the half-size rig's views
  constexpr double kMaxColumnErrPx = 0.05;  // fitted vs true projector column at the points
  const fs::path scan = CopyOfScan("no-projector");
  StereoRig rig = io::ReadRig(Scan() / "rig.json");
  ASSERT_TRUE(rig.projector.has_value());
  const StereoRig truth = rig;
  rig.projector.reset();
  io::WriteRig(scan / "rig.json", rig);
  const ScanSummary with = RunScan(scan, tmp_ / "with", TestOptions());
  ASSERT_EQ(with.status, ScanStatus::kOk) << with.message;
  ASSERT_TRUE(with.projector_columns_used) << with.projector_columns.dump();
  EXPECT_LT(with.projector_columns.at("rms_px").get<double>(), kMaxColumnRmsPx);
  EXPECT_NE(util::ReadTextFile(tmp_ / "with" / "report.html")
                .find("its columns were fitted to this scan"),
            std::string::npos);
  ScanOptions off = TestOptions();
  off.fit_projector_columns = false;
  const ScanSummary without = RunScan(scan, tmp_ / "without", off);
  ASSERT_EQ(without.status, ScanStatus::kOk) << without.message;
  EXPECT_TRUE(without.projector_columns.is_null());
  EXPECT_EQ(without.projector_column_rejected, 0);
  // The dropped points are exactly the difference of the written clouds.
  EXPECT_EQ(without.points - with.points, with.projector_column_rejected);
  int64_t dropped = 0;
  for (const ScanViewSummary& v : with.views) dropped += v.projector_column_rejected;
  EXPECT_EQ(dropped, with.projector_column_rejected);
  EXPECT_LE(with.fused_rms_mm, without.fused_rms_mm);
  // The fitted columns against the true projector at the points of view 000.
  stereo::ProjectorColumnModel model;
  const nlohmann::json& rows = with.projector_columns.at("rows");
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 4; ++c) model.rows(r, c) = rows.at(r).at(c).get<double>();
  }
  const OrganizedPointCloud cloud = io::ReadOrganizedPly(tmp_ / "with" / "views" / "000.ply");
  double worst = 0;
  for (size_t i = 0; i < cloud.valid.size(); ++i) {
    if (!cloud.valid[i]) continue;
    const Eigen::Vector3d& p = cloud.cloud.points[i];
    const double u = truth.projector->Project(truth.projector_from_left * p).x();
    worst = std::max(worst, std::abs(model.Column(p) - u));
  }
  EXPECT_LT(worst, kMaxColumnErrPx);
}

TEST_F(ScanTest, WholeChainMatchesTheTruth) {
  const fs::path out = tmp_ / "out";
  const ScanSummary s = RunScan(Scan(), out, TestOptions());
  EXPECT_EQ(s.status, ScanStatus::kOk) << s.message;
  ASSERT_EQ(s.views.size(), 3u);
  EXPECT_EQ(s.views_ok, 3);
  // The true rig has a projector: the matcher checks it, no columns are fitted.
  EXPECT_TRUE(s.projector_columns.is_null());
  for (const char* f : {"rig.json", "summary.json", "report.html", "poses.json", "markers.json",
                        "fused.ply", "mesh.ply", "mesh.stl"}) {
    EXPECT_TRUE(fs::exists(out / f)) << f;
  }
  // Every view against the truth: its cloud, placed by the true pose, lies on the truth mesh.
  const scan::ScanFolder folder = scan::ScanFolder::Open(Scan());
  const scan::TruthPoses truth = folder.ReadTruthPoses();
  const MeshIndex distance(folder.ReadTruthMesh());
  int64_t points = 0;
  for (int v = 0; v < 3; ++v) {
    const std::string name = s.views[v].name;
    EXPECT_TRUE(s.views[v].ok) << s.views[v].message;
    EXPECT_GT(s.views[v].valid_fraction, kMinValidFraction) << name;
    const OrganizedPointCloud cloud = io::ReadOrganizedPly(out / "views" / (name + ".ply"));
    EXPECT_EQ(static_cast<int>(cloud.NumValid()), s.views[v].points);
    // The markers file is there and lists what the summary counted; enough to register by.
    EXPECT_EQ(static_cast<int>(
                  registration::ReadViewMarkers(out / "views" / (name + ".markers.json")).size()),
              s.views[v].markers);
    EXPECT_GE(s.views[v].markers, 5) << name;
    EXPECT_TRUE(fs::exists(out / "registered" / (name + ".ply"))) << name;
    points += s.views[v].points;
    PointCloud world = cloud.Compact();
    for (auto& p : world.points) p = truth.Find(name)->world_from_sensor * p;
    const eval::DeviationStats dev = eval::DeviationFromMesh(world, distance);
    EXPECT_LT(dev.rms_mm, kMaxViewRmsMm) << name;
  }
  EXPECT_EQ(s.points, points);
  EXPECT_EQ(s.views[0].registration_path, "world");
  EXPECT_EQ(s.views[1].registration_path, "markers");
  EXPECT_EQ(s.views[2].registration_path, "markers");

  // Registration against the truth, recomputed here from poses.json (not the summary's own
  // figure): relative poses of views 1 and 2 to view 0 equal the true ones.
  const auto poses = scan::ReadTruthPoses(out / "poses.json").ByView();
  ASSERT_EQ(poses.size(), 3u);
  const Rigid3d true_0 = truth.Find("000")->world_from_sensor;
  for (const char* name : {"001", "002"}) {
    const Rigid3d true_rel = true_0.Inverse() * truth.Find(name)->world_from_sensor;
    const Rigid3d est_rel = poses.at("000").Inverse() * poses.at(name);
    const double angle_deg = (true_rel.rotation().inverse() * est_rel.rotation())
                                 .angularDistance(Eigen::Quaterniond::Identity()) *
                             180 / M_PI;
    // Displacement at the part (~the view's centre of interest at the working distance).
    const Eigen::Vector3d at_part(0, 0, 400);
    EXPECT_LT(angle_deg, kMaxRotErrDeg) << name;
    EXPECT_LT((true_rel * at_part - est_rel * at_part).norm(), 3 * kMaxTransErrMm) << name;
  }
  // registered/ (written beside the meshing): each view's grid moved by its pose in poses.json,
  // slot for slot (float coordinates in the files).
  constexpr double kFloatStorageMm = 1e-3;
  for (const char* name : {"000", "002"}) {
    const OrganizedPointCloud sensor =
        io::ReadOrganizedPly(out / "views" / (name + std::string(".ply")));
    const OrganizedPointCloud world =
        io::ReadOrganizedPly(out / "registered" / (name + std::string(".ply")));
    ASSERT_EQ(world.valid, sensor.valid) << name;
    double worst_mm = 0;
    for (size_t i = 0; i < sensor.valid.size(); ++i) {
      if (!sensor.valid[i]) continue;
      worst_mm = std::max(worst_mm,
                          (poses.at(name) * sensor.cloud.points[i] - world.cloud.points[i]).norm());
    }
    EXPECT_LT(worst_mm, kFloatStorageMm) << name;
  }
  // The true rig: no view drifted, each checked by its markers and the calibrated projector.
  EXPECT_FALSE(s.calibration_drift);
  EXPECT_EQ(s.drift_views_checked, 3);
  EXPECT_LT(s.epipolar_rms_px, kMaxIntactEpipolarRmsPx);
  for (const ScanViewSummary& v : s.views) {
    EXPECT_TRUE(v.drift.checked) << v.name << ": " << v.drift.message;
    EXPECT_FALSE(v.drift.drift) << v.name << ": " << v.drift.message;
    EXPECT_EQ(v.drift.evidence.size(), 2u) << v.name;
    EXPECT_LT(v.drift.epipolar_systematic_px, kMaxIntactSystematicPx) << v.name;
    EXPECT_LT(std::abs(v.drift.projector_bias_px), kMaxIntactProjectorBiasPx) << v.name;
  }
  EXPECT_TRUE(s.has_truth);
  EXPECT_LT(s.pose_rot_err_deg, kMaxRotErrDeg);
  EXPECT_LT(s.pose_trans_err_mm, kMaxTransErrMm);

  // Fusion and mesh against the truth, the fused cloud recomputed here from fused.ply and the
  // truth of view 000 (world = view 000's sensor frame).
  EXPECT_LT(s.fused_overlap_rms_mm, kFusedOverSingleOverlap * s.single_view_rms_mm);
  EXPECT_LT(s.fused_rms_mm, kMaxFusedRmsMm);
  EXPECT_LT(s.mesh_rms_mm, kMaxMeshRmsMm);
  EXPECT_LT(s.mesh_truth_rms_mm, kMaxMeshRmsMm);  // the truth where measured, to the mesh
  // The single views as fused (estimated poses) and by the sensor alone (true poses) agree to
  // the registration error.
  EXPECT_LT(std::abs(s.single_view_rms_mm - s.single_view_sensor_rms_mm), kMaxTransErrMm);
  PointCloud fused = io::ReadPly(out / "fused.ply").cloud;
  EXPECT_EQ(static_cast<int64_t>(fused.size()), s.fused_points);
  const Rigid3d truth_from_world = true_0 * poses.at("000").Inverse();
  // The summary's gauge (fitted over all views) and view 000's differ by the registration error.
  const Eigen::Vector3d at_part = true_0 * Eigen::Vector3d(0, 0, 400);
  EXPECT_LT((s.truth_from_world * (truth_from_world.Inverse() * at_part) - at_part).norm(),
            3 * kMaxTransErrMm);
  for (auto& p : fused.points) p = truth_from_world * p;
  EXPECT_LT(eval::DeviationFromMesh(fused, distance).rms_mm, kMaxFusedRmsMm);
  const TriangleMesh mesh = io::ReadMesh(out / "mesh.ply");
  EXPECT_EQ(static_cast<int64_t>(mesh.NumTriangles()), s.mesh_triangles);
  EXPECT_EQ(io::ReadMesh(out / "mesh.stl").NumTriangles(), mesh.NumTriangles());

  const auto summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["views_ok"].get<int>(), 3);
  EXPECT_FALSE(summary["calibration_drift"].get<bool>());
  // A rig given, not calibrated here: no calibration report, no calibration warnings.
  EXPECT_FALSE(fs::exists(out / "calibration"));
  EXPECT_FALSE(summary.contains("calibration_report"));
  EXPECT_TRUE(summary["calibration_warnings"].empty());
  EXPECT_TRUE(summary["epipolar_rms_px"].is_number());
  for (const auto& v : summary["view_results"]) {
    EXPECT_TRUE(v["epipolar_rms_px"].is_number());
    EXPECT_FALSE(v["drift"].get<bool>());
  }
  EXPECT_EQ(summary["points"].get<int64_t>(), points);
  EXPECT_EQ(summary["status"].get<std::string>(), "ok");
  for (const char* key :
       {"views", "points", "calibrate_s", "total_s", "read_s", "decode_s", "reconstruct_s",
        "register_s", "fuse_s", "mesh_s", "report_s", "peak_mem_gib", "pose_rot_err_deg",
        "pose_trans_err_mm", "fused_rms_mm", "single_view_rms_mm"}) {
    EXPECT_TRUE(summary.contains(key) && summary[key].is_number()) << key;
  }
  // The report is self-contained: every picture is embedded and decodes.
  const std::string html = util::ReadTextFile(out / "report.html");
  int sources = 0;
  const std::vector<cv::Mat> images = io::testing::EmbeddedImages(html, &sources);
  // Per view: phase, depth, modulation, texture with markers; then residual histograms (one per
  // ICP level, before and after ICP), the marker map, mesh renderings and the deviation maps.
  const auto& levels = summary["registration"]["icp"]["levels"];
  ASSERT_FALSE(levels.empty());
  for (const auto& l : levels) {
    int64_t counted = 0;
    for (const auto& c : l["residual_histogram"]["counts"]) counted += c.get<int64_t>();
    EXPECT_EQ(counted, l["residual_histogram"]["samples"].get<int64_t>());
    EXPECT_GT(counted, 100);
    EXPECT_LE(l["residual_p50_mm"].get<double>(), l["residual_p90_mm"].get<double>());
  }
  EXPECT_GE(sources, 12 + 4 + 4 + 2 + 3 + static_cast<int>(levels.size()));
  // One deviation map per view against the truth (the sensor alone), captioned with its RMS.
  for (const ScanViewSummary& v : s.views) {
    EXPECT_TRUE(std::isfinite(v.truth_rms_mm)) << v.name;
    EXPECT_LT(v.truth_rms_mm, kMaxViewRmsMm) << v.name;
    const std::string caption = "view " + v.name + ": signed deviation from the truth";
    EXPECT_NE(html.find(caption), std::string::npos) << caption;
  }
  EXPECT_EQ(static_cast<int>(images.size()), sources);
  // No external URL: no source or link but the embedded ones (the viewer script names the XHTML
  // namespace, "http://www.w3.org/1999/xhtml", which is no request).
  for (const char* external : {"src=\"http", "src=\"//", "href=\"http", "href=\"//"}) {
    EXPECT_EQ(html.find(external), std::string::npos) << external;
  }
  // The 3D view: its container, scene and the viewer script.
  EXPECT_NE(html.find("<div class=\"fringe-scene\""), std::string::npos);
  EXPECT_NE(html.find("id=\"fringe-scene-0-arrays\""), std::string::npos);
  EXPECT_NE(html.find("fringeViewer"), std::string::npos);
}

// The right camera rotated by 0.02 degrees about its x axis (pitch: a vertical disparity the
// markers show, 0.44 px on this half-size rig) and its y axis (yaw: a change of depth that only
// the projector shows): both pieces of evidence flag every view, and the report warns.
TEST_F(ScanTest, DriftedRightCameraIsFlaggedByMarkersAndProjector) {
  const fs::path scan = CopyOfScan("drifted");
  StereoRig rig = io::ReadRig(Scan() / "rig.json");
  const double angle_rad = 0.02 * M_PI / 180;
  rig.right_from_left =
      Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitX(), angle_rad, Eigen::Vector3d::Zero()) *
      Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitY(), angle_rad, Eigen::Vector3d::Zero()) *
      rig.right_from_left;
  io::WriteRig(scan / "rig.json", rig);
  ScanOptions o = TestOptions();
  o.evaluate_truth = false;
  const fs::path out = tmp_ / "out";
  const ScanSummary s = RunScan(scan, out, o);
  EXPECT_TRUE(s.calibration_drift);
  EXPECT_EQ(s.drift_views_checked, 3);
  for (const ScanViewSummary& v : s.views) {
    ASSERT_TRUE(v.ok) << v.name << ": " << v.message;
    EXPECT_TRUE(v.drift.drift) << v.name;
    EXPECT_GT(v.drift.epipolar_systematic_px, o.drift.max_epipolar_systematic_px) << v.name;
    EXPECT_GT(std::abs(v.drift.projector_bias_px), o.drift.max_projector_bias_px) << v.name;
    EXPECT_NE(v.drift.message.find("markers' systematic epipolar"), std::string::npos)
        << v.drift.message;
    EXPECT_NE(v.drift.message.find("projector column"), std::string::npos) << v.drift.message;
  }
  const auto summary = io::ReadJson(out / "summary.json");
  EXPECT_TRUE(summary["calibration_drift"].get<bool>());
  EXPECT_TRUE(summary["view_results"][0]["drift"].get<bool>());
  EXPECT_NE(util::ReadTextFile(out / "report.html").find("WARNING: calibration drift"),
            std::string::npos);
}

// `fringe refine` on the same scan with the right camera turned by 0.03 degrees about each axis:
// the bundle over the views' phase points (right phase, projector columns) and markers brings
// it back to the truth, writes the refined rig with its summary, and a scan with it no longer
// drifts. On this half-size rig (markers ~0.11 px noise, 3 views, ~5600 phase points, the
// projector holding the scale) the refined orientation is within 0.0016 degrees of the truth.
TEST_F(ScanTest, RefineRecoversADriftedRigFromTheScan) {
  constexpr double kMaxRefinedRotErrDeg = 0.005;
  const fs::path scan = CopyOfScan("refine");
  const StereoRig truth = io::ReadRig(Scan() / "rig.json");
  StereoRig rig = truth;
  const double a = 0.03 * M_PI / 180;
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  rig.right_from_left = Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitX(), a, zero) *
                        Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitY(), a, zero) *
                        Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitZ(), a, zero) *
                        truth.right_from_left;
  io::WriteRig(scan / "rig.json", rig);
  const fs::path out = tmp_ / "refined.json";
  const RefineResult r = RefineScanRig(scan, out, RefineOptions());
  ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
  const auto angle_deg = [](const Rigid3d& x, const Rigid3d& y) {
    return x.rotation().angularDistance(y.rotation()) * 180 / M_PI;
  };
  EXPECT_LT(angle_deg(r.rig.right_from_left, truth.right_from_left), kMaxRefinedRotErrDeg)
      << r.summary.BriefReport();
  EXPECT_GT(r.summary.refinement.marker_epipolar_rms_before_px,
            2 * r.summary.refinement.marker_epipolar_rms_after_px);
  ASSERT_TRUE(fs::exists(out));
  const StereoRig written = io::ReadRig(out);
  EXPECT_LT(angle_deg(written.right_from_left, r.rig.right_from_left), 1e-9);
  const nlohmann::json j = io::ReadJson(out);
  EXPECT_EQ(j.at("refinement").at("status").get<std::string>(), "ok");
  EXPECT_FALSE(j.at("refinement").at("parameters").empty());
  // `fringe scan --refine` refines the rig first, uses it, and its view no longer drifts; on
  // the first view alone (the refinement above is its accuracy test, this one the wiring).
  const fs::path one_view = tmp_ / "refine-one-view";
  fs::copy(scan, one_view, fs::copy_options::recursive);
  for (const char* view : {"001", "002"}) fs::remove_all(one_view / "views" / view);
  nlohmann::json manifest = io::ReadJson(one_view / "scan.json");
  manifest["views"] = 1;
  io::WriteJson(one_view / "scan.json", manifest);
  ScanOptions o = TestOptions();
  o.refine = true;
  o.evaluate_truth = false;
  o.write_report = false;
  const ScanSummary s = RunScan(one_view, tmp_ / "out", o);
  EXPECT_TRUE(s.rig_refined) << s.refinement.dump();
  EXPECT_EQ(s.drift_views_checked, 1);
  EXPECT_FALSE(s.calibration_drift);
}

// A camera + projector scan folder made from the stereo one (the same rendered left images):
// the right camera's folders removed, scan.json saying one camera; rig.json stays the true rig,
// whose left camera and projector the scan uses.
fs::path CameraProjectorScan(const fs::path& copy) {
  for (const char* view : {"000", "001", "002"}) fs::remove_all(copy / "views" / view / "right");
  nlohmann::json manifest = io::ReadJson(copy / "scan.json");
  manifest["cameras"] = 1;
  io::WriteJson(copy / "scan.json", manifest);
  return copy;
}

TEST_F(ScanTest, CameraProjectorScanMatchesTheTruth) {
  const fs::path scan = CameraProjectorScan(CopyOfScan("camera-projector"));
  const fs::path out = tmp_ / "out";
  const ScanSummary s = RunScan(scan, out, TestOptions());
  EXPECT_EQ(s.status, ScanStatus::kOk) << s.message;
  EXPECT_FALSE(s.stereo);
  ASSERT_EQ(s.views.size(), 3u);
  EXPECT_EQ(s.views_ok, 3);
  const scan::ScanFolder folder = scan::ScanFolder::Open(scan);
  EXPECT_FALSE(folder.stereo());
  const scan::TruthPoses truth = folder.ReadTruthPoses();
  const MeshIndex distance(folder.ReadTruthMesh());
  for (const ScanViewSummary& v : s.views) {
    EXPECT_TRUE(v.ok) << v.message;
    EXPECT_GT(v.valid_fraction, kMinValidFraction) << v.name;
    EXPECT_GE(v.markers, 5) << v.name;  // measured in the one camera
    // The view's cloud placed by its true pose lies on the truth mesh (recomputed here).
    PointCloud world = io::ReadOrganizedPly(out / "views" / (v.name + ".ply")).Compact();
    for (auto& p : world.points) p = truth.Find(v.name)->world_from_sensor * p;
    EXPECT_LT(eval::DeviationFromMesh(world, distance).rms_mm, kMaxViewRmsMm) << v.name;
  }
  std::cout << s.BriefReport() << "\n";
  EXPECT_LT(s.pose_rot_err_deg, kMaxRotErrDeg);
  EXPECT_LT(s.pose_trans_err_mm, kMaxTransErrMmCameraProjector);
  EXPECT_LT(s.fused_rms_mm, kMaxFusedRmsMm);
  EXPECT_LT(s.mesh_rms_mm, kMaxMeshRmsMm);
  EXPECT_TRUE(fs::exists(out / "mesh.stl"));
  const auto summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["mode"].get<std::string>(), "camera-projector");
  // The rig written is the one used: a camera and its projector.
  EXPECT_TRUE(io::ReadRig(out / "rig.json").projector.has_value());
  EXPECT_NE(util::ReadTextFile(out / "report.html").find("projector"), std::string::npos);
}

TEST_F(ScanTest, CameraProjectorScanCalibratesFromItsBoardPoseFolders) {
  // No rig.json: the camera and projector are calibrated from calibration/KKK/ (board image and
  // both fringe directions per pose, as `fringe calibrate` reads them), 6 poses at half size,
  // in a camera + projector scan folder written by the simulator (sim::ScanOptions::cameras).
  const fs::path scan = tmp_ / "camera-projector-calib";
  SimulateHalfSizeDemoScan(scan, [](sim::ScanOptions* o) {
    o->cameras = 1;
    o->calibration_images = 6;
  });
  fs::remove(scan / "rig.json");
  const StereoRig rig = scan::ScanFolder::Open(scan).ReadTruthRig();
  ScanOptions o = TestOptions();
  o.projector_calibration.features.window_radius_px = 10;  // half resolution
  o.write_report = false;
  const fs::path out = tmp_ / "out";
  const ScanSummary s = RunScan(scan, out, o);
  std::cout << s.BriefReport() << "\n";
  EXPECT_EQ(s.views_ok, 3);
  EXPECT_NE(s.calibration_source.find("camera + projector"), std::string::npos);
  EXPECT_GT(s.calibration_rms_left_px, 0);
  EXPECT_GT(s.calibration_rms_projector_px, 0);
  const StereoRig est = io::ReadRig(out / "rig.json");
  ASSERT_TRUE(est.projector.has_value());
  // The calibrated projector is the true one (the bounds of calib/projector_test at this size).
  EXPECT_LT(std::abs(est.projector->fx - rig.projector->fx) / rig.projector->fx, 3e-4);
  EXPECT_LT((est.projector_from_left.translation() - rig.projector_from_left.translation()).norm(),
            0.1);
  EXPECT_LT(s.pose_rot_err_deg, kMaxRotErrDeg);
  EXPECT_LT(s.pose_trans_err_mm, kMaxTransErrMmCameraProjector);
  EXPECT_LT(s.fused_rms_mm, kMaxFusedRmsMm);
  // --no-report: no calibration report either.
  EXPECT_TRUE(s.calibration_report.empty());
  EXPECT_FALSE(fs::exists(out / "calibration"));
}

TEST_F(ScanTest, CameraProjectorScanWithoutProjectorCalibrationFailsNamingTheRig) {
  const fs::path scan = CameraProjectorScan(CopyOfScan("camera-projector-noproj"));
  StereoRig rig = io::ReadRig(scan / "rig.json");
  rig.projector.reset();
  io::WriteRig(scan / "rig.json", rig);
  const fs::path out = tmp_ / "out";
  try {
    RunScan(scan, out, TestOptions());
    FAIL() << "a camera + projector scan needs a calibrated projector";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("rig.json"), std::string::npos) << m;
    EXPECT_NE(m.find("no calibrated projector"), std::string::npos) << m;
  }
  EXPECT_FALSE(fs::exists(out));
}

// A camera + projector scan written by the simulator itself (sim::ScanOptions::cameras = 1):
// the demo part on the half-size rig, 3 views, vertical AND horizontal fringes, two exposures
// (e0/ at 1.5 times the reference exposure, bright parts saturated; e1/ at 0.5). rig.json is
// the true rig.
class OneCameraScanTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    SimulateHalfSizeDemoScan(*dir_ / "scan", [](sim::ScanOptions* o) {
      o->cameras = 1;
      o->both_directions = true;
      o->exposures = {1.5, 0.5};
    });
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path Scan() { return *dir_ / "scan"; }
  // The same views reduced to one direction and/or one exposure (the files moved into the
  // layout of such a scan): the same rendered images, so the comparison isolates the decoding.
  fs::path Reduced(const std::string& name, bool both_directions, bool exposures) const {
    const fs::path copy = tmp_ / name;
    fs::copy(Scan(), copy, fs::copy_options::recursive);
    for (const char* view : {"000", "001", "002"}) {
      const fs::path left = copy / "views" / view / "left";
      for (const char* d : {"vertical", "horizontal"}) {
        if (!exposures) {
          fs::remove_all(left / d / "e1");
          for (const auto& e : fs::directory_iterator(left / d / "e0")) {
            fs::rename(e.path(), left / d / e.path().filename());
          }
          fs::remove(left / d / "e0");
        }
      }
      if (!both_directions) {
        fs::remove_all(left / "horizontal");
        for (const auto& e : fs::directory_iterator(left / "vertical")) {
          fs::rename(e.path(), left / e.path().filename());
        }
        fs::remove(left / "vertical");
      }
    }
    if (!both_directions) {
      nlohmann::json manifest = io::ReadJson(copy / "scan.json");
      manifest.erase("scheme_horizontal");
      io::WriteJson(copy / "scan.json", manifest);
      fs::remove(copy / "scheme_horizontal.json");
    }
    return copy;
  }

  static test::TempDir* dir_;
  test::TempDir tmp_;
};
test::TempDir* OneCameraScanTest::dir_ = nullptr;

TEST_F(OneCameraScanTest, BothDirectionsAndExposuresMatchTheTruth) {
  // The scan with both directions and both exposures, and the same rendered images reduced to
  // the vertical fringes at the first exposure: each within the camera + projector bounds
  // against the truth, and the second projector coordinate makes the views closer to the truth
  // (two-ray triangulation in camera and projector instead of the ray against the projector
  // column; measured 0.0405 vs 0.0427 mm single-view RMS, fused 0.0323 vs 0.0344 mm). The
  // figures are printed (docs/scan-folder.md quotes them).
  ScanOptions o = TestOptions();
  o.write_report = false;
  struct Case {
    const char* name;
    bool both_directions, exposures;
  };
  std::map<std::string, ScanSummary> result;
  for (const Case& c :
       {Case{"both-directions-two-exposures", true, true}, Case{"vertical", false, false}}) {
    const fs::path scan =
        c.both_directions && c.exposures ? Scan() : Reduced(c.name, c.both_directions, c.exposures);
    const scan::ScanFolder folder = scan::ScanFolder::Open(scan);
    EXPECT_EQ(folder.both_directions(), c.both_directions) << c.name;
    const ScanSummary s = RunScan(scan, tmp_ / (std::string("out-") + c.name), o);
    SCOPED_TRACE(c.name);
    EXPECT_EQ(s.status, ScanStatus::kOk) << s.message;
    EXPECT_FALSE(s.stereo);
    ASSERT_EQ(s.views_ok, 3);
    for (const ScanViewSummary& v : s.views) {
      EXPECT_GT(v.valid_fraction, kMinValidFraction) << v.name;
      EXPECT_GE(v.markers, 5) << v.name;
      EXPECT_LT(v.truth_rms_mm, kMaxViewRmsMm) << v.name;
      // The second direction is decoded (the decoded fraction of the horizontal stack).
      if (c.both_directions) {
        EXPECT_GT(v.decode_valid_right, kMinValidFraction) << v.name;
      } else {
        EXPECT_EQ(v.decode_valid_right, 0.0) << v.name;
      }
      // Drift: two directions give a redundant projector coordinate, the true rig passes; one
      // direction has nothing redundant and says so.
      EXPECT_EQ(v.drift.checked, c.both_directions) << v.name << ": " << v.drift.message;
      EXPECT_FALSE(v.drift.drift) << v.name << ": " << v.drift.message;
      if (c.both_directions) {
        EXPECT_EQ(v.drift.epipolar_source, "two-direction phase");
        std::cout << v.name << ": two-direction residual RMS " << v.drift.epipolar_rms_px
                  << " px\n";
      } else {
        EXPECT_NE(v.drift.message.find("not checked"), std::string::npos) << v.drift.message;
      }
    }
    EXPECT_LT(s.pose_rot_err_deg, kMaxRotErrDeg);
    EXPECT_LT(s.pose_trans_err_mm, kMaxTransErrMmCameraProjector);
    EXPECT_LT(s.fused_rms_mm, kMaxFusedRmsMm);
    EXPECT_LT(s.mesh_rms_mm, kMaxMeshRmsMm);
    std::cout << c.name << ": single-view RMS (all points, true poses) " << s.single_view_all_rms_mm
              << " mm, in the overlaps " << s.single_view_rms_mm << " mm, fused " << s.fused_rms_mm
              << " mm, points " << s.points << ", pose " << s.pose_rot_err_deg << " deg / "
              << s.pose_trans_err_mm << " mm\n";
    result[c.name] = s;
  }
  const ScanSummary& both = result.at("both-directions-two-exposures");
  const ScanSummary& vertical = result.at("vertical");
  EXPECT_LT(both.single_view_all_rms_mm, vertical.single_view_all_rms_mm);
  EXPECT_LT(both.fused_rms_mm, vertical.fused_rms_mm);
}

TEST_F(ScanTest, MissingImageFailsNamingTheViewAndFileAndWritesNothing) {
  const fs::path scan = CopyOfScan("missing");
  fs::remove(scan / "views" / "001" / "right" / "05.png");
  const fs::path out = tmp_ / "out";
  try {
    RunScan(scan, out, TestOptions());
    FAIL() << "a missing image must fail the scan";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("view 001"), std::string::npos) << m;
    EXPECT_NE(m.find("05.png"), std::string::npos) << m;
    EXPECT_NE(m.find("'read'"), std::string::npos) << m;
    EXPECT_NE(m.find("views that worked: 000, 002"), std::string::npos) << m;
  }
  EXPECT_FALSE(fs::exists(out));
  for (const auto& e : fs::directory_iterator(tmp_.path())) {
    EXPECT_EQ(e.path().filename().string().find("out"), std::string::npos)
        << "left behind: " << e.path();
  }
}

TEST_F(ScanTest, KeepGoingFinishesWithoutATruncatedViewAndNamesIt) {
  const fs::path scan = CopyOfScan("truncated");
  const fs::path png = scan / "views" / "002" / "left" / "03.png";
  fs::resize_file(png, fs::file_size(png) / 3);
  ScanOptions o = TestOptions();
  const fs::path out = tmp_ / "out";
  // Without keep_going: the error names the view, the file and the stage; nothing is written.
  const std::string message = test::ErrorOf([&] { RunScan(scan, out, o); });
  EXPECT_NE(message.find("view 002 failed in stage 'read'"), std::string::npos) << message;
  EXPECT_NE(message.find("03.png"), std::string::npos) << message;
  EXPECT_NE(message.find("views that worked: 000, 001"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));
  o.keep_going = true;
  const ScanSummary s = RunScan(scan, out, o);
  EXPECT_EQ(s.status, ScanStatus::kPartial);
  EXPECT_EQ(s.views_ok, 2);
  ASSERT_EQ(s.views.size(), 3u);
  EXPECT_FALSE(s.views[2].ok);
  EXPECT_EQ(s.views[2].failed_stage, "read");
  EXPECT_NE(s.views[2].message.find("03.png"), std::string::npos) << s.views[2].message;
  EXPECT_TRUE(fs::exists(out / "views" / "000.ply"));
  EXPECT_TRUE(fs::exists(out / "views" / "001.ply"));
  EXPECT_FALSE(fs::exists(out / "views" / "002.ply"));
  EXPECT_EQ(scan::ReadTruthPoses(out / "poses.json").ByView().size(), 2u);
  EXPECT_TRUE(fs::exists(out / "mesh.stl"));
  const auto summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["status"].get<std::string>(), "partial");
  EXPECT_EQ(summary["view_results"][2]["failed_stage"].get<std::string>(), "read");
  const std::string html = util::ReadTextFile(out / "report.html");
  EXPECT_NE(html.find("View 002 was left out"), std::string::npos);
}

TEST_F(ScanTest, CorruptCalibrationFailsNamingTheFile) {
  const fs::path scan = CopyOfScan("badcal");
  std::ofstream(scan / "rig.json", std::ios::trunc) << "{\"cameras\": [ {\"fx\": ";
  const fs::path out = tmp_ / "out";
  try {
    RunScan(scan, out);
    FAIL() << "a corrupt calibration must fail the scan";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("rig.json"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(ScanTest, WrongCalibrationIsRefusedAndWritesNothing) {
  // A valid file for another rig (full-size cameras for quarter-size images).
  const fs::path scan = CopyOfScan("wrongcal");
  io::WriteRig(scan / "rig.json", StereoRig::Reference());
  const fs::path out = tmp_ / "out";
  ScanOptions o = TestOptions();
  o.keep_going = true;  // even so: the rig does not fit the images, so there is no result
  try {
    RunScan(scan, out, o);
    FAIL() << "a calibration for other images must fail the scan";
  } catch (const Error& e) {
    // Refused before any view is read, naming both descriptions of the camera (issue 30).
    const std::string m = e.what();
    EXPECT_NE(
        m.find((scan / "rig.json").string() + ": the left camera is calibrated at 1280 x 1024"),
        std::string::npos)
        << m;
    EXPECT_NE(m.find("scan.json says the images are"), std::string::npos) << m;
  }
  EXPECT_FALSE(fs::exists(out));
}

// Paints every marker of `view` out of all its fringe images (a uniform dark disk over each, as
// if the marker had been covered), using the truth's projected marker centres.
void RemoveMarkers(const fs::path& scan_dir, const std::string& view) {
  const scan::ScanFolder folder = scan::ScanFolder::Open(scan_dir);
  const scan::TruthMarkers truth = folder.ReadTruthMarkers();
  const StereoRig rig = folder.ReadTruthRig();
  const scan::ViewMarkers* seen = truth.Find(view);
  ASSERT_NE(seen, nullptr);
  const phase::PatternScheme scheme = folder.ReadScheme();
  for (const scan::Camera camera : {scan::Camera::kLeft, scan::Camera::kRight}) {
    for (const std::string& image : scheme.ImageNames()) {
      const fs::path path = folder.layout().CameraDir(view, camera) / image;
      cv::Mat m = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(m.empty()) << path;
      for (const scan::MarkerObservation& o : seen->observations) {
        const Eigen::Vector2d px = camera == scan::Camera::kLeft ? o.left_px : o.right_px;
        if (!px.allFinite()) continue;
        const double r_px = 2.0 * 2.5 * rig.left.fx / std::max(1.0, o.centre_in_sensor.z());
        cv::circle(m, cv::Point(static_cast<int>(px.x()), static_cast<int>(px.y())),
                   static_cast<int>(std::ceil(r_px)), cv::Scalar(20), cv::FILLED);
      }
      ASSERT_TRUE(cv::imwrite(path.string(), m)) << path;
    }
  }
}

TEST_F(ScanTest, ViewWithoutMarkersFailsRegistrationNamingIt) {
  const fs::path scan = CopyOfScan("nomarkers");
  RemoveMarkers(scan, "002");
  // The marker-free fallback is switched off: the view must then fail in 'register'.
  ScanOptions o = TestOptions();
  o.registration.coarse_fallback = false;
  const fs::path out = tmp_ / "out";
  try {
    RunScan(scan, out, o);
    FAIL() << "a view without markers and without the fallback must fail the scan";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("view 002 failed in stage 'register'"), std::string::npos) << m;
    EXPECT_NE(m.find("0 markers measured"), std::string::npos) << m;
    EXPECT_NE(m.find("views that worked: 000, 001"), std::string::npos) << m;
  }
  EXPECT_FALSE(fs::exists(out));
  // With keep_going: the result without view 002, the summary and report naming it.
  o.keep_going = true;
  const ScanSummary s = RunScan(scan, out, o);
  EXPECT_EQ(s.status, ScanStatus::kPartial);
  EXPECT_EQ(s.views_ok, 2);
  EXPECT_FALSE(s.views[2].ok);
  EXPECT_EQ(s.views[2].failed_stage, "register");
  EXPECT_EQ(s.views[2].markers, 0);
  const auto poses = scan::ReadTruthPoses(out / "poses.json").ByView();
  EXPECT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses.count("002"), 0u);
  EXPECT_FALSE(fs::exists(out / "registered" / "002.ply"));
  EXPECT_TRUE(fs::exists(out / "mesh.ply"));
  EXPECT_NE(util::ReadTextFile(out / "report.html").find("View 002 was left out"),
            std::string::npos);
}

// A small scan (quarter-size rig, 2 views of the sphere, no truth maps) simulated into
// `scan_dir`, and quick scan options using its true rig.
ScanOptions SmallSphereScan(const fs::path& scan_dir) {
  sim::ScanOptions o;
  o.scene = "sphere";
  o.views = 2;
  o.calibration_images = 0;
  o.render.sensor.supersampling = 1;
  o.truth_maps = false;
  sim::SimulateScan(sim::ScaledRig(StereoRig::Reference(), 0.25), o, scan_dir);
  ScanOptions options;
  options.calib = scan_dir / "truth" / "rig.json";
  options.mesh.poisson_depth = 7;
  return options;
}

TEST(Scan, ResultsDoNotDependOnTheThreadCount) {
  // A small marker-free scan (quarter-size rig, 2 views of the sphere) run on one thread and on
  // all: the same poses, fused cloud and mesh, byte for byte.
  test::TempDir dir;
  ScanOptions options = SmallSphereScan(dir / "scan");
  options.write_report = false;
  RunScan(dir / "scan", dir / "all", options);
  tbb::task_arena(1).execute([&] { RunScan(dir / "scan", dir / "one", options); });
  for (const char* f : {"poses.json", "views/000.ply", "views/001.ply", "registered/001.ply",
                        "fused.ply", "mesh.ply"}) {
    EXPECT_EQ(util::ReadTextFile(dir / "all" / f), util::ReadTextFile(dir / "one" / f)) << f;
  }
}

TEST(Scan, FusionInTilesMatchesTheWholeAtOnce) {
  // The small sphere scan fused at once and in tiles of 20 mm, streamed from OUT/views/: the
  // same poses, most fused points the same (within 1 um), and the fused cloud as close to the
  // truth (the target, 1.05 x the whole-at-once RMS). The cloud-to-cloud tolerance of
  // tiling itself is fusion/tiles_test.cc's; on this scan's real borders ~1 % of the points
  // differ by about a point spacing (rim points fused otherwise within a tile).
  constexpr double kMinEqualFraction = 0.9;
  constexpr double kEqualMm = 1e-3;
  constexpr double kMaxRmsRatio = 1.05;
  test::TempDir dir;
  ScanOptions options = SmallSphereScan(dir / "scan");
  options.write_report = false;
  const ScanSummary whole = RunScan(dir / "scan", dir / "whole", options);
  EXPECT_EQ(whole.fusion_tiles, 1);
  options.fusion_tile_mm = 20;
  const ScanSummary tiled = RunScan(dir / "scan", dir / "tiled", options);
  EXPECT_GE(tiled.fusion_tiles, 2);
  EXPECT_EQ(tiled.fusion_tile_mm, 20);
  EXPECT_FALSE(fs::exists(dir / "tiled" / ".fusion_tiles"));  // the pieces are gone
  EXPECT_EQ(util::ReadTextFile(dir / "whole" / "poses.json"),
            util::ReadTextFile(dir / "tiled" / "poses.json"));
  ASSERT_TRUE(std::isfinite(whole.fused_rms_mm) && std::isfinite(tiled.fused_rms_mm));
  EXPECT_LE(tiled.fused_rms_mm, kMaxRmsRatio * whole.fused_rms_mm);
  const PointCloud a = io::ReadPly(dir / "whole" / "fused.ply").cloud;
  const PointCloud b = io::ReadPly(dir / "tiled" / "fused.ply").cloud;
  for (const auto& [from, to] : {std::pair{&a, &b}, std::pair{&b, &a}}) {
    const PointIndex index(to->points);
    size_t equal = 0;
    for (const Eigen::Vector3d& p : from->points)
      equal += index.Nearest(p).second <= kEqualMm * kEqualMm;
    EXPECT_GE(double(equal) / double(from->size()), kMinEqualFraction);
  }
  for (const char* f : {"mesh.ply", "registered/000.ply", "registered/001.ply"})
    EXPECT_TRUE(fs::exists(dir / "tiled" / f)) << f;
}

// Every regular file below `dir` (relative path) with its contents.
std::map<std::string, std::string> FolderContents(const fs::path& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) {
      out[e.path().lexically_relative(dir).generic_string()] = util::ReadTextFile(e.path());
    }
  }
  return out;
}

TEST(Scan, FullDiskFailsCleanlyNamingTheFileAndTheStage) {
  // A full disk simulated by a file size limit (tests/file_size_limit.h: a file cannot grow past
  // the limit, its write fails with EFBIG as a full disk's fails with ENOSPC). A successful scan
  // gives the output's file sizes; the files in the order the scan writes them, with their
  // stage: a limit equal to the largest file written before F makes F the first write to fail.
  // One limit per stage that can fail that way; each run must fail with an error naming the
  // stage, the file (inside OUT, not the temporary folder) and the reason, leave the previous
  // OUT as it was and no temporary folder, and not touch the scan folder.
  test::TempDir dir;
  const ScanOptions options = SmallSphereScan(dir / "scan");
  const fs::path out = dir / "out";
  RunScan(dir / "scan", out, options);
  const std::map<std::string, std::string> inputs = FolderContents(dir / "scan");
  const std::map<std::string, std::string> before = FolderContents(out);

  const std::vector<std::pair<std::string, std::string>> order = {
      {"calibrate", "rig.json"},
      {"write", "views/000.markers.json"},
      {"write", "views/000.ply"},
      {"write", "views/001.markers.json"},
      {"write", "views/001.ply"},
      {"register", "registered/000.ply"},
      {"register", "registered/001.ply"},
      {"register", "poses.json"},
      {"register", "markers.json"},
      {"fuse", "fused.ply"},
      {"mesh", "mesh.ply"},
      {"mesh", "mesh.stl"},
      {"report", "report.html"},
      {"summary", "summary.json"}};
  std::map<std::string, std::pair<uint64_t, std::string>> limit_of_stage;  // first file per stage
  uint64_t largest = before.at(util::kOutputMarkerName).size();
  for (const auto& [stage, file] : order) {
    ASSERT_TRUE(before.count(file)) << file;
    const uint64_t size = before.at(file).size();
    // The two views are written in parallel: a view file fails first only when larger than
    // both views' files of the other kind too.
    if (size > largest && !limit_of_stage.count(stage)) limit_of_stage[stage] = {largest, file};
    largest = std::max<uint64_t>(largest, size);
  }
  // At least the calibration, the views and one stage after them can be made to fail.
  ASSERT_GE(limit_of_stage.size(), 3u);
  for (const auto& [stage, limit_file] : limit_of_stage) {
    const auto& [limit, file] = limit_file;
    for (const bool keep_going : {false, true}) {
      ScanOptions o = options;
      o.keep_going = keep_going;  // a full disk is no bad view: fatal with keep_going too
      std::string message;
      {
        const test::FileSizeLimit full(limit);
        message = test::ErrorOf([&] { RunScan(dir / "scan", out, o); });
      }
      SCOPED_TRACE(stage + " " + file + " keep_going " + std::to_string(keep_going));
      if (!keep_going) std::cout << "limit " << limit << " bytes: " << message << "\n";
      ASSERT_FALSE(message.empty()) << "a full disk must fail the scan";
      EXPECT_NE(message.find("stage '" + stage + "'"), std::string::npos) << message;
      if (stage == "write") {
        // Either view may fail first (they run in parallel).
        EXPECT_NE(message.find((out / "views").string() + "/00"), std::string::npos) << message;
      } else {
        EXPECT_NE(message.find((out / file).string()), std::string::npos) << message;
      }
      EXPECT_NE(message.find("cannot write: File too large"), std::string::npos) << message;
      EXPECT_EQ(message.find(".tmp"), std::string::npos) << message;
      EXPECT_EQ(FolderContents(out), before) << "the previous OUT must stay as it was";
      std::vector<std::string> left;
      for (const auto& e : fs::directory_iterator(dir.path())) {
        left.push_back(e.path().filename().string());
      }
      EXPECT_EQ(left.size(), 2u) << "a temporary was left behind";
      EXPECT_EQ(FolderContents(dir / "scan"), inputs) << "the scan folder was changed";
    }
  }
}

TEST_F(ScanTest, MemoryLimitTooSmallForOneViewIsAClearError) {
  // A view of this scan (2 x 12 images of 640 x 512 px) needs ~0.07 GiB: 0.05 GiB is refused
  // before anything is written, naming the option and the sizes.
  ScanOptions options = TestOptions();
  options.memory_limit_gib = 0.05;
  const std::string message = test::ErrorOf([&] { RunScan(Scan(), tmp_ / "out", options); });
  EXPECT_NE(message.find("--memory-limit"), std::string::npos) << message;
  EXPECT_NE(message.find("too small for one view"), std::string::npos) << message;
  EXPECT_NE(message.find("640 x 512"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(tmp_ / "out"));
  options.memory_limit_gib = -1;
  EXPECT_THROW(options.Check(), Error);
}

TEST_F(ScanTest, UnwritableOutputFailsBeforeWriting) {
  // The parent of OUT is a file (as root, permissions would not stop the write).
  std::ofstream(tmp_ / "file") << "x";
  EXPECT_THROW(RunScan(Scan(), tmp_ / "file" / "out"), Error);
#ifndef _WIN32
  // A read-only parent (effective only when not root): the error names OUT, nothing is left.
  fs::create_directories(tmp_ / "ro");
  fs::permissions(tmp_ / "ro", fs::perms::owner_read | fs::perms::owner_exec);
  if (::geteuid() != 0) {
    EXPECT_THROW(RunScan(Scan(), tmp_ / "ro" / "out", TestOptions()), Error);
    EXPECT_FALSE(fs::exists(tmp_ / "ro" / "out"));
  }
  fs::permissions(tmp_ / "ro", fs::perms::owner_all);
#endif
  EXPECT_THROW(RunScan(Scan(), tmp_ / "no" / "such" / "out"), Error);
  // A folder the user made (no fringe marker) is never replaced: refused before the work.
  fs::create_directories(tmp_ / "mine");
  std::ofstream(tmp_ / "mine" / "notes.txt") << "keep";
  const std::string message = test::ErrorOf([&] { RunScan(Scan(), tmp_ / "mine"); });
  EXPECT_NE(message.find("was not written by fringe"), std::string::npos) << message;
  EXPECT_EQ(util::ReadTextFile(tmp_ / "mine" / "notes.txt"), "keep");
  EXPECT_THROW(RunScan(tmp_ / "nonexistent-project", tmp_ / "out"), Error);
  EXPECT_FALSE(fs::exists(tmp_ / "out"));
}

}  // namespace
}  // namespace fringe::pipeline
