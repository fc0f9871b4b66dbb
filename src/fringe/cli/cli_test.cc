#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "fringe/cli/cli.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/ply.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/registration_io.h"
#include "fringe/sim/scan.h"
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

// fringe register on a folder of view PLYs with markers beside them: a wavy surface seen from
// three poses, markers stuck on it; poses.json gets every view, relative to the first.
TEST(Cli, RegisterWritesPoses) {
  test::TempDir dir;
  auto height = [](double x, double y) {
    return 6 * std::sin(x / 15) * std::cos(y / 19) + 0.003 * x * x;
  };
  std::vector<Eigen::Vector3d> marker_world;
  for (int k = 0; k < 10; ++k) {
    const double x = -50 + 11 * k, y = (k % 3 - 1) * 25 + k;
    marker_world.emplace_back(x, y, height(x, y));
  }
  std::vector<Rigid3d> world_from_sensor;
  for (int v = 0; v < 3; ++v) {
    world_from_sensor.push_back(
        Rigid3d::FromAxisAngle(Eigen::Vector3d(0.1 * v, 1, 0.2).normalized(), M_PI + 0.15 * (v - 1),
                               Eigen::Vector3d(5.0 * v, -3.0 * v, 450)));
  }
  for (int v = 0; v < 3; ++v) {
    const Rigid3d sensor_from_world = world_from_sensor[v].Inverse();
    PointCloud c;
    for (double x = -70; x <= 70; x += 0.7) {
      for (double y = -50; y <= 50; y += 0.7) {
        const double z = height(x, y);
        const double dzdx = 6 / 15.0 * std::cos(x / 15) * std::cos(y / 19) + 0.006 * x;
        const double dzdy = -6 / 19.0 * std::sin(x / 15) * std::sin(y / 19);
        c.points.push_back(sensor_from_world * Eigen::Vector3d(x, y, z));
        c.normals.push_back(
            sensor_from_world.RotateDirection(Eigen::Vector3d(-dzdx, -dzdy, 1).normalized()));
      }
    }
    const std::string name = "view" + std::to_string(v);
    io::WritePly(dir / (name + ".ply"), c);
    std::vector<registration::ViewMarker> markers;
    for (size_t k = 0; k < marker_world.size(); ++k) {
      registration::ViewMarker m;
      m.id = static_cast<int>(k);
      m.centre_in_sensor = sensor_from_world * marker_world[k];
      m.normal_in_sensor = sensor_from_world.RotateDirection(Eigen::Vector3d::UnitZ());
      m.outer_radius_mm = 2.5;
      m.sigma_mm = 0.02;
      markers.push_back(m);
    }
    registration::WriteViewMarkers(dir / (name + ".markers.json"), markers);
  }
  std::string out, err;
  ASSERT_EQ(RunCli({"register", (dir / "view0.ply").string(), (dir / "view1.ply").string(),
                    (dir / "view2.ply").string(), "--out", (dir / "reg").string()},
                   &out, &err),
            0)
      << out << err;
  const auto poses = registration::ReadPoses(dir / "reg" / "poses.json");
  ASSERT_EQ(poses.size(), 3u);
  for (int v = 0; v < 3; ++v) {
    const Rigid3d expected = world_from_sensor[0].Inverse() * world_from_sensor[v];
    const RigidDifference d = Difference(poses.at("view" + std::to_string(v)), expected);
    EXPECT_LT(d.angle_rad * 180 / M_PI, 0.01) << v;
    EXPECT_LT(d.translation_mm, 0.05) << v;
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "reg" / "registered" / "view2.ply"));
  EXPECT_TRUE(std::filesystem::exists(dir / "reg" / "markers.json"));
  // An output folder holding an input is refused, the inputs untouched.
  EXPECT_EQ(
      RunCli({"register", (dir / "view0.ply").string(), "--out", dir.path().string()}, &out, &err),
      1);
  EXPECT_TRUE(std::filesystem::exists(dir / "view0.ply"));
}

}  // namespace
}  // namespace fringe::cli
