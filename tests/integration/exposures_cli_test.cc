// Several exposures of one view through `fringe decode` and `fringe reconstruct` (issue 10):
// a dark plate with a bright, specular-like patch, rendered by the simulator at a short and a
// long exposure (the sensor's gain per exposure). The short exposure loses the dark plate to
// low modulation, the long one the patch to saturation; the exposure folders e0/ and e1/
// together cover both.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/cli/run_cli_for_test.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/ply.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/stack_io.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scene.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/files.h"

namespace fringe {
namespace {

namespace fs = std::filesystem;

void WriteStack(const fs::path& dir, const phase::PatternScheme& scheme,
                const std::vector<cv::Mat>& images) {
  fs::create_directories(dir);
  const auto names = scheme.ImageNames();
  for (size_t i = 0; i < images.size(); ++i) io::WriteImage(dir / names[i], images[i]);
}

TEST(ExposuresCli, TwoExposuresCoverMoreThanEitherAlone) {
  constexpr double kShortExposure = 0.6;
  constexpr double kLongExposure = 6.0;  // the sensor's gain between the two
  constexpr double kPatchRadiusMm = 30;
  const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.25);
  const phase::PatternScheme scheme =
      phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  sim::Scene scene;
  sim::SceneObject plate;
  plate.name = "plate";
  plate.mesh = sim::MakeRectangleMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                      Eigen::Vector3d::UnitY(), 260, 200, 10);
  // Dark part, and a patch of the brightest diffuse albedo standing in for a specular highlight.
  plate.texture = [&](const Eigen::Vector3d& p) {
    return p.head<2>().norm() < kPatchRadiusMm ? 1.0 : 0.05;
  };
  scene.AddObject(plate);
  const Rigid3d world_from_sensor = sim::SensorPoseLookingAt(
      rig, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, -0.3, 1).normalized());
  const auto patterns = phase::GeneratePatterns(scheme);
  test::TempDir tmp;
  const fs::path view = tmp / "view";
  for (int e = 0; e < 2; ++e) {
    sim::RenderOptions options;
    options.projector.gamma = 1.0;
    options.truth = false;
    options.sensor.exposure = e == 0 ? kShortExposure : kLongExposure;
    const sim::Renderer renderer(scene, rig, options);
    const auto images = renderer.RenderView(world_from_sensor, patterns);
    WriteStack(phase::ExposureDir(view / "left", e), scheme, images.left.images);
    WriteStack(phase::ExposureDir(view / "right", e), scheme, images.right.images);
    // Single-exposure views for the comparison.
    const fs::path single = tmp / util::StrCat("single", e);
    WriteStack(single / "left", scheme, images.left.images);
    WriteStack(single / "right", scheme, images.right.images);
    phase::WriteScheme(single / "manifest.json", scheme);
    io::WriteRig(single / "rig.json", rig);
  }
  phase::WriteScheme(view / "manifest.json", scheme);
  io::WriteRig(view / "rig.json", rig);

  // decode: the summary lists both exposures; the combination covers more than either.
  std::string out, err;
  ASSERT_EQ(cli::RunCli({"decode", (view / "left").string(), "--scheme",
                         (view / "manifest.json").string(), "--out", (tmp / "dec").string()},
                        &out, &err),
            0)
      << out << err;
  const nlohmann::json summary =
      nlohmann::json::parse(util::ReadTextFile(tmp / "dec" / "summary.json"));
  ASSERT_EQ(summary.at("exposures").size(), 2u) << summary.dump();
  const int64_t both = summary.at("valid").get<int64_t>();
  const int64_t short_only = summary["exposures"][0]["valid"].get<int64_t>();
  const int64_t long_only = summary["exposures"][1]["valid"].get<int64_t>();
  std::cout << "left pixels valid: short " << short_only << ", long " << long_only << ", both "
            << both << "\n";
  EXPECT_GT(both, short_only);
  EXPECT_GT(both, long_only);
  // Each exposure supplies a real share (the patch from the short one, the plate from the long).
  EXPECT_GT(summary["exposures"][0]["chosen"].get<int64_t>(), 1000);
  EXPECT_GT(summary["exposures"][1]["chosen"].get<int64_t>(), 1000);

  // reconstruct: more points from both exposures than from either alone.
  auto points = [&](const fs::path& dir, const std::string& name) {
    const std::string ply = (tmp / (name + ".ply")).string();
    std::string o, e;
    EXPECT_EQ(cli::RunCli({"reconstruct", dir.string(), "--out", ply, "--no-markers"}, &o, &e), 0)
        << o << e;
    return io::ReadOrganizedPly(ply).NumValid();
  };
  const size_t points_both = points(view, "both");
  const size_t points_short = points(tmp / "single0", "short");
  const size_t points_long = points(tmp / "single1", "long");
  std::cout << "points: short " << points_short << ", long " << points_long << ", both "
            << points_both << "\n";
  EXPECT_GT(points_both, points_short);
  EXPECT_GT(points_both, points_long);
}

}  // namespace
}  // namespace fringe
