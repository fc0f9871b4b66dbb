// End to end on a small simulated scan (scaled-down rig, 3 views of the demo part): accuracy of
// every view against the simulator's truth, and failure injection (missing or truncated image,
// corrupt calibration, unwritable output): each gives its clear error and leaves OUT without
// partial results, or with --keep-going a complete result without the bad view.
#include "fringe/pipeline/scan.h"

#include <gtest/gtest.h>

#include <fstream>

#include "fringe/eval/deviation.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/mesh_io.h"
#include "fringe/io/ply.h"
#include "fringe/pipeline/report_test_util.h"
#include "fringe/registration/markers.h"
#include "fringe/sim/scan.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe_test.h"

namespace fringe::pipeline {
namespace {

namespace fs = std::filesystem;

// A view of the demo part on the quarter-size rig (320 x 256 px, ~0.6 mm per pixel): noise and
// sampling make single points scatter ~0.1 mm; the view's RMS to the truth mesh stays below.
constexpr double kMaxViewRmsMm = 0.25;
constexpr double kMinValidFraction = 0.2;  // the part and its plate fill much of the image

class ScanTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    sim::ScanOptions o;
    o.scene = "demo";
    o.views = 3;
    o.calibration_images = 0;
    o.precompensate_gamma = 2.2;
    o.render.sensor.supersampling = 1;
    const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.25);
    sim::SimulateScan(rig, o, *dir_ / "scan");
    fs::copy_file(*dir_ / "scan" / "truth" / "rig.json", *dir_ / "scan" / "rig.json");
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

TEST_F(ScanTest, ReconstructsEveryViewAccurately) {
  const fs::path out = tmp_ / "out";
  const ScanSummary s = RunScan(Scan(), out);
  EXPECT_EQ(s.status, ScanStatus::kOk);
  ASSERT_EQ(s.views.size(), 3u);
  EXPECT_EQ(s.views_ok, 3);
  for (const char* f : {"rig.json", "summary.json", "report.html", "views/000.ply", "views/001.ply",
                        "views/002.ply"}) {
    EXPECT_TRUE(fs::exists(out / f)) << f;
  }
  // Every view against the truth: its cloud, placed by the true pose, lies on the truth mesh.
  const auto poses = io::ReadJson(Scan() / "truth" / "poses.json");
  const eval::MeshDistance distance(io::ReadMesh(Scan() / "truth" / "scene.ply"));
  int64_t points = 0;
  for (int v = 0; v < 3; ++v) {
    const std::string name = s.views[v].name;
    EXPECT_TRUE(s.views[v].ok) << s.views[v].message;
    EXPECT_GT(s.views[v].valid_fraction, kMinValidFraction) << name;
    const OrganizedPointCloud cloud = io::ReadOrganizedPly(out / "views" / (name + ".ply"));
    EXPECT_EQ(static_cast<int>(cloud.NumValid()), s.views[v].points);
    // The markers file is there and lists what the summary counted.
    EXPECT_EQ(static_cast<int>(
                  registration::ReadViewMarkers(out / "views" / (name + ".markers.json")).size()),
              s.views[v].markers);
    points += s.views[v].points;
    const Rigid3d world_from_sensor =
        io::RigidFromJson(poses["views"][v]["world_from_sensor"], "poses");
    PointCloud world = cloud.Compact();
    for (auto& p : world.points) p = world_from_sensor * p;
    const eval::DeviationStats dev = eval::DeviationFromMesh(world, distance);
    EXPECT_LT(dev.rms_mm, kMaxViewRmsMm) << name;
  }
  EXPECT_EQ(s.points, points);
  const auto summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["views_ok"].get<int>(), 3);
  EXPECT_EQ(summary["points"].get<int64_t>(), points);
  EXPECT_EQ(summary["status"].get<std::string>(), "ok");
  // The report is self-contained: every picture is embedded and decodes.
  const std::string html = util::ReadTextFile(out / "report.html");
  int sources = 0;
  const std::vector<cv::Mat> images = testing::EmbeddedImages(html, &sources);
  EXPECT_GE(sources, 9);  // per view: depth, modulation, texture with markers
  EXPECT_EQ(static_cast<int>(images.size()), sources);
  EXPECT_EQ(html.find("://"), std::string::npos);  // no external URL (base64 has no colon)
}

TEST_F(ScanTest, MissingImageFailsNamingTheViewAndFileAndWritesNothing) {
  const fs::path scan = CopyOfScan("missing");
  fs::remove(scan / "views" / "001" / "right" / "05.png");
  const fs::path out = tmp_ / "out";
  try {
    RunScan(scan, out);
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
  ScanOptions o;
  o.keep_going = true;
  const fs::path out = tmp_ / "out";
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

TEST_F(ScanTest, WrongCalibrationFailsEveryViewAndWritesNothing) {
  // A valid file for another rig (full-size cameras for quarter-size images).
  const fs::path scan = CopyOfScan("wrongcal");
  io::WriteRig(scan / "rig.json", StereoRig::Reference());
  const fs::path out = tmp_ / "out";
  ScanOptions o;
  o.keep_going = true;  // even so: no view works, so there is no result
  try {
    RunScan(scan, out, o);
    FAIL() << "a calibration for other images must fail the scan";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("no view worked"), std::string::npos) << m;
    EXPECT_NE(m.find("'reconstruct'"), std::string::npos) << m;
  }
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(ScanTest, UnwritableOutputFailsBeforeWriting) {
  // The parent of OUT is a file (as root, permissions would not stop the write).
  std::ofstream(tmp_ / "file") << "x";
  EXPECT_THROW(RunScan(Scan(), tmp_ / "file" / "out"), Error);
  EXPECT_THROW(RunScan(Scan(), tmp_ / "no" / "such" / "out"), Error);
  EXPECT_THROW(RunScan(tmp_ / "nonexistent-project", tmp_ / "out"), Error);
  EXPECT_FALSE(fs::exists(tmp_ / "out"));
}

}  // namespace
}  // namespace fringe::pipeline
