// The calibration flags every command shares (cli/calibration_flags.h, pipeline::LookUpRig):
// one rig given as a rig JSON, as an OpenCV file (--calib or --opencv), as two ROS files
// (--opencv twice) or as the OpenCV pair gives the same result in `scan` and `reconstruct`;
// conflicting flags are refused naming them, before anything is written.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/cli/run_cli_for_test.h"
#include "fringe/io/json.h"
#include "fringe/io/ply.h"
#include "fringe/sim/scan.h"
#include "fringe/testing/fringe_test.h"

namespace fringe::cli {
namespace {

namespace fs = std::filesystem;

class CalibrationFlags : public ::testing::Test {
 protected:
  // A small stereo scan and its true rig in every file kind (shared: simulating is the cost).
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    sim::ScanOptions o;
    o.scene = "sphere";
    o.views = 2;
    o.calibration_images = 0;
    o.render.sensor.supersampling = 1;
    sim::SimulateScan(sim::ScaledRig(StereoRig::Reference(), 0.25), o, Dir() / "scan");
    const std::string rig = (Dir() / "scan/truth/rig.json").string();
    std::string err;
    ASSERT_EQ(RunCli({"convert-calib", rig, "--to", "opencv", "--out", Path("stereo.yml")}, nullptr,
                     &err),
              0)
        << err;
    ASSERT_EQ(RunCli({"convert-calib", rig, "--to", "ros", "--out", Path("left.yaml"),
                      Path("right.yaml")},
                     nullptr, &err),
              0)
        << err;
    // stereo_calib's pair: M1 D1 M2 D2 in one file, R T in the other.
    cv::FileStorage in(Path("stereo.yml"), cv::FileStorage::READ);
    cv::FileStorage intrinsics(Path("intrinsics.yml"), cv::FileStorage::WRITE);
    for (const char* k : {"M1", "D1", "M2", "D2"}) intrinsics << k << in[k].mat();
    cv::FileStorage extrinsics(Path("extrinsics.yml"), cv::FileStorage::WRITE);
    for (const char* k : {"R", "T"}) extrinsics << k << in[k].mat();
  }
  static void TearDownTestSuite() { delete dir_; }
  static const fs::path& Dir() { return dir_->path(); }
  static std::string Path(const std::string& name) { return (Dir() / name).string(); }
  static std::string View() { return Path("scan/views/000"); }

  // `fringe reconstruct` of view 000 with `calibration` flags: its number of points. The
  // projector check is off: the ROS files and the pair hold no projector, the others do.
  static size_t Reconstruct(const std::vector<std::string>& calibration, const std::string& out) {
    std::vector<std::string> args = {
        "-q",           "reconstruct",           View(), "--out", Path(out),
        "--no-markers", "--max-projector-error", "0"};
    args.insert(args.end(), calibration.begin(), calibration.end());
    std::string err;
    EXPECT_EQ(RunCli(args, nullptr, &err), 0) << err;
    return fs::exists(Path(out)) ? io::ReadOrganizedPly(Path(out)).NumValid() : 0;
  }

  static test::TempDir* dir_;
};
test::TempDir* CalibrationFlags::dir_ = nullptr;

TEST_F(CalibrationFlags, ReconstructReadsEveryKindOfCalibrationAlike) {
  const size_t points = Reconstruct({"--calib", Path("scan/truth/rig.json")}, "rig.ply");
  ASSERT_GT(points, 1000u);
  EXPECT_EQ(Reconstruct({"--calib", Path("stereo.yml")}, "calib_opencv.ply"), points);
  EXPECT_EQ(Reconstruct({"--opencv", Path("stereo.yml")}, "opencv.ply"), points);
  EXPECT_EQ(Reconstruct({"--opencv", Path("left.yaml"), "--opencv", Path("right.yaml")},
                        "opencv_twice.ply"),
            points);
  EXPECT_EQ(Reconstruct({"--opencv-intrinsics", Path("intrinsics.yml"), "--opencv-extrinsics",
                         Path("extrinsics.yml")},
                        "pair.ply"),
            points);
}

// `scan --calib` takes another tool's file as `reconstruct --opencv` does (it used to refuse it
// as "not a fringe rig file").
TEST_F(CalibrationFlags, ScanCalibTakesAnOpenCvFile) {
  std::string err;
  ASSERT_EQ(RunCli({"-q", "scan", Path("scan"), "--calib", Path("stereo.yml"), "--out", Path("out"),
                    "--poisson-depth", "7", "--no-report"},
                   nullptr, &err),
            0)
      << err;
  const nlohmann::json summary = io::ReadJson(Dir() / "out" / "summary.json");
  EXPECT_EQ(summary["views_ok"].get<int>(), 2);
  EXPECT_EQ(summary.dump().find(Path("stereo.yml")) != std::string::npos, true)
      << "the summary names the calibration file";
}

TEST_F(CalibrationFlags, ConflictingFlagsAreRefusedNamingThem) {
  const std::string rig = Path("scan/truth/rig.json");
  struct Case {
    std::vector<std::string> args;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {{"reconstruct", View(), "--out", Path("x.ply"), "--calib", rig, "--opencv",
        Path("stereo.yml")},
       "either with --calib or as OpenCV files"},
      {{"reconstruct", View(), "--out", Path("x.ply"), "--opencv-intrinsics",
        Path("intrinsics.yml")},
       "--opencv-intrinsics and --opencv-extrinsics"},
      {{"reconstruct", View(), "--out", Path("x.ply"), "--opencv", Path("stereo.yml"),
        "--opencv-intrinsics", Path("intrinsics.yml"), "--opencv-extrinsics",
        Path("extrinsics.yml")},
       "--opencv or as the --opencv-intrinsics/--opencv-extrinsics pair"},
      {{"scan", Path("scan"), "--out", Path("x"), "--calib", rig, "--opencv-intrinsics",
        Path("intrinsics.yml"), "--opencv-extrinsics", Path("extrinsics.yml")},
       "not both"},
      {{"scan", Path("scan"), "--out", Path("x"), "--calib", rig, "--opencv-keys", "left=Kc,kc"},
       "--opencv-keys"},
      {{"refine", Path("scan"), "--out", Path("x.json"), "--opencv-extrinsics",
        Path("extrinsics.yml")},
       "--opencv-intrinsics and --opencv-extrinsics"},
      {{"check", Path("scan"), "--artefact", rig, "--out", Path("x"), "--calib", rig, "--opencv",
        Path("stereo.yml")},
       "not both"},
  };
  for (const Case& c : cases) {
    std::string err;
    EXPECT_EQ(RunCli(c.args, nullptr, &err), 1) << c.args[0] << ": " << err;
    EXPECT_NE(err.find(c.expected), std::string::npos) << c.args[0] << ": " << err;
  }
  for (const char* out : {"x.ply", "x", "x.json"}) EXPECT_FALSE(fs::exists(Dir() / out)) << out;
}

}  // namespace
}  // namespace fringe::cli
