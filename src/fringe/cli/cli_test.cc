#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include "fringe/calib/calibrate_folder.h"
#include "fringe/cli/cli.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/ply.h"
#include "fringe/sim/scan.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe_test.h"

namespace fringe::cli {
namespace {

int RunCli(std::vector<std::string> args, std::string* out = nullptr, std::string* err = nullptr) {
  args.insert(args.begin(), "fringe");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const int rc = Main(static_cast<int>(argv.size()), argv.data());
  const std::string o = testing::internal::GetCapturedStdout();
  const std::string e = testing::internal::GetCapturedStderr();
  if (out) *out = o;
  if (err) *err = e;
  return rc;
}

TEST(Cli, HelpListsSubcommandsAndVersion) {
  std::string out;
  EXPECT_EQ(RunCli({"--help"}, &out), 0);
  EXPECT_NE(out.find("info"), std::string::npos);
  EXPECT_NE(out.find("demo"), std::string::npos);
  EXPECT_EQ(RunCli({"--version"}, &out), 0);
  EXPECT_NE(out.find("fringe "), std::string::npos);
}

TEST(Cli, UsageErrorsExitWith2) {
  std::string err;
  EXPECT_EQ(RunCli({"frobnicate"}, nullptr, &err), 2);
  EXPECT_NE(err.find("usage error"), std::string::npos) << err;
  EXPECT_EQ(RunCli({"info", "--no-such-flag", "x"}), 2);
  EXPECT_EQ(RunCli({}), 2);
}

TEST(Cli, InfoOnPlyAndTruncatedPly) {
  test::TempDir dir;
  PointCloud c;
  for (int i = 0; i < 1000; ++i) c.points.emplace_back(i, 2 * i, 3 * i);
  io::WritePly(dir / "c.ply", c);
  std::string out, err;
  EXPECT_EQ(RunCli({"info", (dir / "c.ply").string()}, &out), 0);
  EXPECT_NE(out.find("points: 1000"), std::string::npos) << out;
  const std::string data = util::ReadTextFile(dir / "c.ply");
  {
    std::ofstream f(dir / "t.ply", std::ios::binary);
    f << data.substr(0, data.size() / 2);
  }
  EXPECT_EQ(RunCli({"info", (dir / "t.ply").string()}, &out, &err), 1);
  EXPECT_NE(err.find("t.ply: truncated"), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << "one-line error: " << err;
}

TEST(Cli, ScanKeepGoingExitsWith3AndFailureExitsWith1) {
  test::TempDir dir;
  sim::ScanOptions o;
  o.scene = "sphere";
  o.views = 2;
  o.calibration_images = 0;
  o.render.sensor.supersampling = 1;
  sim::SimulateScan(sim::ScaledRig(StereoRig::Reference(), 0.25), o, dir / "scan");
  std::filesystem::remove(dir / "scan" / "views" / "001" / "left" / "00.png");
  const std::string rig = (dir / "scan" / "truth" / "rig.json").string();
  const std::string scan = (dir / "scan").string(), out = (dir / "out").string();
  std::string stdout_text, err;
  EXPECT_EQ(RunCli({"--threads", "1", "scan", scan, "--calib", rig, "--out", out}, nullptr, &err),
            1);
  EXPECT_NE(err.find("view 001"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
  EXPECT_EQ(RunCli({"-q", "--threads", "1", "scan", scan, "--calib", rig, "--out", out,
                    "--keep-going", "--json"},
                   &stdout_text, &err),
            3)
      << err;
  EXPECT_NE(stdout_text.find("\"status\": \"partial\""), std::string::npos) << stdout_text;
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "views" / "000.ply"));
  EXPECT_EQ(RunCli({"--threads", "-1", "scan", scan, "--out", out}), 2);
}

// What `fringe calibrate` writes for one camera is a rig file the readers and `fringe info`
// accept (issue 9: ReadRig used to throw "missing 'cameras'").
TEST(Cli, InfoAndReadRigOnASingleCameraCalibration) {
  test::TempDir dir;
  calib::FolderCalibration cal;
  cal.stereo = false;
  cal.mono.camera = StereoRig::Reference().left;
  cal.mono.summary.final_rms_px = 0.125;
  calib::WriteFolderCalibration(dir / "mono.json", cal);
  const StereoRig rig = io::ReadRig(dir / "mono.json");
  EXPECT_TRUE(rig.left == cal.mono.camera);
  EXPECT_EQ(rig.BaselineMm(), 0.0);  // no second camera: a stereo consumer's Check() refuses it
  EXPECT_THROW(rig.Check(), Error);
  std::string out, err;
  EXPECT_EQ(RunCli({"info", (dir / "mono.json").string()}, &out, &err), 0) << err;
  EXPECT_NE(out.find("single-camera calibration"), std::string::npos) << out;
  EXPECT_NE(out.find("1280x1024"), std::string::npos) << out;
}

}  // namespace
}  // namespace fringe::cli
