// One simulated view through `fringe reconstruct` and `fringe evaluate`.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/cli/cli.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/mesh_io.h"
#include "fringe/io/ply.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scene.h"
#include "fringe_test.h"

namespace fringe {
namespace {

int RunCli(std::vector<std::string> args, std::string* out = nullptr, std::string* err = nullptr) {
  args.insert(args.begin(), "fringe");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  const int rc = cli::Main(static_cast<int>(argv.size()), argv.data());
  const std::string o = ::testing::internal::GetCapturedStdout();
  const std::string e = ::testing::internal::GetCapturedStderr();
  if (out) *out = o;
  if (err) *err = e;
  return rc;
}

void WriteStack(const std::filesystem::path& dir, const phase::PatternScheme& scheme,
                const std::vector<cv::Mat>& images) {
  std::filesystem::create_directories(dir);
  const auto names = scheme.ImageNames();
  for (size_t i = 0; i < images.size(); ++i) io::WriteImage(dir / names[i], images[i]);
}

TEST(ReconstructCli, SimulatedSphereViewToVdiFigures) {
  // Quarter-resolution reference rig: one disparity pixel ~2.5 mm of depth, so the tolerances
  // are ~4x those of the full-resolution benchmark.
  constexpr double kPsTolMm = 0.1;
  constexpr double kPfMaxMm = 0.6;
  constexpr double kDeviationRmsTolMm = 0.1;
  constexpr double kRadiusMm = 15;
  const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.25);
  const phase::PatternScheme scheme =
      phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  const sim::Scene scene = sim::MakeSphereScene(kRadiusMm);
  sim::RenderOptions options;
  options.projector.gamma = 1.0;
  const sim::Renderer renderer(scene, rig, options);
  const Rigid3d world_from_sensor = sim::SensorPoseLookingAt(
      rig, Eigen::Vector3d(0, 0, kRadiusMm), Eigen::Vector3d(0, -0.4, 1).normalized());
  const sim::ViewImages view =
      renderer.RenderView(world_from_sensor, phase::GeneratePatterns(scheme));

  const test::TempDir tmp;
  const auto dir = tmp / "view";
  WriteStack(dir / "left", scheme, view.left.images);
  WriteStack(dir / "right", scheme, view.right.images);
  phase::WriteScheme(dir / "manifest.json", scheme);
  io::WriteRig(dir / "rig.json", rig);
  io::WriteMesh(tmp / "truth.ply", scene.CombinedMesh());
  io::WriteJson(tmp / "pose.json", io::RigidToJson(world_from_sensor));

  std::string out, err;
  const std::string ply = (tmp / "cloud.ply").string();
  ASSERT_EQ(RunCli({"reconstruct", dir.string(), "--out", ply}, &out, &err), 0) << out << err;
  const OrganizedPointCloud cloud = io::ReadOrganizedPly(ply);
  EXPECT_EQ(cloud.width, rig.left.width);
  EXPECT_GT(cloud.NumValid(), 20000u);
  // --json: one JSON object with every stage's summary, and the same cloud.
  const std::string ply_json = (tmp / "cloud_json.ply").string();
  ASSERT_EQ(RunCli({"reconstruct", dir.string(), "--out", ply_json, "--json"}, &out, &err), 0)
      << out << err;
  const nlohmann::json rj = nlohmann::json::parse(out);
  EXPECT_EQ(rj.at("mode"), "stereo");
  EXPECT_EQ(rj.at("summary").at("status"), "ok");
  EXPECT_EQ(rj.at("summary").at("points").get<size_t>(), cloud.NumValid());
  EXPECT_GT(rj.at("summary").at("decode_left").at("valid").get<int64_t>(), 20000);
  EXPECT_EQ(io::ReadOrganizedPly(ply_json).NumValid(), cloud.NumValid());

  ASSERT_EQ(RunCli({"evaluate", ply, "--artefact", "sphere", "--diameter",
                    std::to_string(2 * kRadiusMm), "--json"},
                   &out, &err),
            0)
      << out << err;
  const auto j = nlohmann::json::parse(out);
  ASSERT_EQ(j["sphere"]["status"], "ok") << out;
  EXPECT_LT(std::abs(j["sphere"]["PS_mm"].get<double>()), kPsTolMm) << out;
  EXPECT_LT(j["sphere"]["PF_mm"].get<double>(), kPfMaxMm) << out;
  // Without --diameter: the same sphere with a free radius, form figures and fitted diameter,
  // no PS.
  ASSERT_EQ(RunCli({"evaluate", ply, "--artefact", "sphere", "--json"}, &out, &err), 0)
      << out << err;
  const auto free = nlohmann::json::parse(out);
  ASSERT_EQ(free["sphere"]["status"], "ok") << out;
  EXPECT_FALSE(free["sphere"].contains("PS_mm")) << out;
  EXPECT_NEAR(free["sphere"]["diameter_mm"].get<double>(), 2 * kRadiusMm, kPsTolMm) << out;
  EXPECT_LT(free["sphere"]["PF_mm"].get<double>(), kPfMaxMm) << out;
  EXPECT_GT(free["sphere"]["rms_mm"].get<double>(), 0) << out;

  const std::string map = (tmp / "deviation.png").string();
  ASSERT_EQ(RunCli({"evaluate", ply, "--truth", (tmp / "truth.ply").string(), "--pose",
                    (tmp / "pose.json").string(), "--map", map, "--json"},
                   &out, &err),
            0)
      << out << err;
  const auto d = nlohmann::json::parse(out);
  EXPECT_LT(d["deviation"]["rms_mm"].get<double>(), kDeviationRmsTolMm) << out;
  EXPECT_GT(d["deviation"]["points"].get<int>(), 20000) << out;
  EXPECT_TRUE(std::filesystem::exists(map));

  // A view where the projector lit nothing: a clear error, exit code 1, no output file.
  const auto dark_dir = tmp / "dark";
  const std::vector<cv::Mat> dark(scheme.NumImages(),
                                  cv::Mat(rig.left.height, rig.left.width, CV_8UC1, cv::Scalar(3)));
  WriteStack(dark_dir / "left", scheme, dark);
  WriteStack(dark_dir / "right", scheme, dark);
  const std::string dark_ply = (tmp / "dark.ply").string();
  EXPECT_EQ(RunCli({"reconstruct", dark_dir.string(), "--calib", (dir / "rig.json").string(),
                    "--scheme", (dir / "manifest.json").string(), "--out", dark_ply},
                   &out, &err),
            1);
  EXPECT_NE(err.find("no valid pixels"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(dark_ply));
}

}  // namespace
}  // namespace fringe
