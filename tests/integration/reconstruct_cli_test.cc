// One simulated view through `fringe reconstruct` and `fringe evaluate`.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
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
#include "fringe/testing/fringe_test.h"

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

// A sphere of radius_mm seen by the quarter-resolution reference rig (heterodyne-4x3).
struct QuarterRigSphere {
  explicit QuarterRigSphere(double radius_mm) : scene(sim::MakeSphereScene(radius_mm)) {}
  StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.25);
  phase::PatternScheme scheme =
      phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  sim::Scene scene;

  // Renders the view and writes it as a view folder: left/, right/, manifest.json, rig.json.
  sim::ViewImages WriteView(const std::filesystem::path& dir, const Rigid3d& world_from_sensor,
                            const sim::RenderOptions& options) const {
    const sim::ViewImages view =
        sim::Renderer(scene, rig, options)
            .RenderView(world_from_sensor, phase::GeneratePatterns(scheme));
    WriteStack(dir / "left", scheme, view.left.images);
    WriteStack(dir / "right", scheme, view.right.images);
    phase::WriteScheme(dir / "manifest.json", scheme);
    io::WriteRig(dir / "rig.json", rig);
    return view;
  }
};

TEST(ReconstructCli, SimulatedSphereViewToVdiFigures) {
  // Quarter-resolution reference rig: one disparity pixel ~2.5 mm of depth, so the tolerances
  // are ~4x those of the full-resolution benchmark.
  constexpr double kPsTolMm = 0.1;
  constexpr double kPfMaxMm = 0.6;
  constexpr double kDeviationRmsTolMm = 0.1;
  constexpr double kRadiusMm = 15;
  const QuarterRigSphere sphere(kRadiusMm);
  const StereoRig& rig = sphere.rig;
  const phase::PatternScheme& scheme = sphere.scheme;
  const sim::Scene& scene = sphere.scene;
  sim::RenderOptions options;
  options.projector.gamma = 1.0;
  const Rigid3d world_from_sensor = sim::SensorPoseLookingAt(
      rig, Eigen::Vector3d(0, 0, kRadiusMm), Eigen::Vector3d(0, -0.4, 1).normalized());
  const test::TempDir tmp;
  const auto dir = tmp / "view";
  sphere.WriteView(dir, world_from_sensor, options);
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

// Issue 10 through the command line: a 12-bit view (16-bit PNGs holding 0..4095) with
// --bit-depth 12 gives the 8-bit view's coverage and texture on the 0-255 scale, and
// --min-modulation sets the decoder's threshold (as `fringe decode` does).
TEST(ReconstructCli, TwelveBitViewWithBitDepthAndMinModulation) {
  constexpr double kCoverageTolerance = 0.01;
  constexpr double kTextureToleranceDn = 1.0;
  constexpr double kRadiusMm = 15;
  const QuarterRigSphere sphere(kRadiusMm);
  const Rigid3d world_from_sensor = sim::SensorPoseLookingAt(
      sphere.rig, Eigen::Vector3d(0, 0, kRadiusMm), Eigen::Vector3d(0.3, -0.4, 1).normalized());
  const test::TempDir tmp;
  for (const int bits : {8, 12}) {
    sim::RenderOptions options;
    options.projector.gamma = 1.0;
    options.sensor.supersampling = 2;
    options.sensor.bit_depth = bits;
    options.sensor.read_noise_dn *= options.sensor.FullScale() / 255.0;  // same SNR
    sphere.WriteView(tmp / ("view" + std::to_string(bits)), world_from_sensor, options);
  }
  const auto run = [&](const std::string& name, std::vector<std::string> extra) {
    std::vector<std::string> args = {
        "reconstruct", (tmp / name).string(), "--json", "--out",
        (tmp / (name + "_" + std::to_string(extra.size()) + ".ply")).string()};
    args.insert(args.end(), extra.begin(), extra.end());
    std::string out, err;
    EXPECT_EQ(RunCli(args, &out, &err), 0) << err;
    return nlohmann::json::parse(out.empty() ? "{}" : out);
  };
  const auto mean_texture = [&](const std::string& ply) {
    const OrganizedPointCloud cloud = io::ReadOrganizedPly((tmp / ply).string());
    double sum = 0;
    for (size_t i = 0; i < cloud.valid.size(); ++i) {
      if (cloud.valid[i]) sum += cloud.cloud.intensity[i];
    }
    return sum / std::max<size_t>(cloud.NumValid(), 1);
  };
  const nlohmann::json j8 = run("view8", {});
  const nlohmann::json j12 = run("view12", {"--bit-depth", "12"});
  ASSERT_TRUE(j8.contains("summary") && j12.contains("summary"));
  EXPECT_EQ(j12["summary"]["decode_left"]["full_scale_dn"].get<double>(), 4095.0);
  const double n8 = j8["summary"]["points"].get<double>();
  const double n12 = j12["summary"]["points"].get<double>();
  ASSERT_GT(n8, 10000);
  EXPECT_NEAR(n12 / n8, 1.0, kCoverageTolerance);
  const double texture8 = mean_texture("view8_0.ply");
  EXPECT_GT(texture8, 20.0);  // a real texture, not a scaled-down one
  EXPECT_NEAR(mean_texture("view12_2.ply"), texture8, kTextureToleranceDn);

  // --min-modulation: the given threshold, reported as given, and fewer points above it.
  const double b_min = 2 * j8["summary"]["decode_left"]["min_modulation_dn"].get<double>();
  const nlohmann::json strict = run("view8", {"--min-modulation", std::to_string(b_min)});
  ASSERT_TRUE(strict.contains("summary"));
  EXPECT_NEAR(strict["summary"]["decode_left"]["min_modulation_dn"].get<double>(), b_min, 1e-6);
  EXPECT_LT(strict["summary"]["points"].get<double>(), n8);
  EXPECT_GT(strict["summary"]["decode_left"]["rejected_low_modulation"].get<int64_t>(),
            j8["summary"]["decode_left"]["rejected_low_modulation"].get<int64_t>());
}

// Issue 10: a calibration written by another tool is read as it is: one OpenCV YAML holding
// both cameras and their extrinsics (cameraMatrix1/distCoeffs1/cameraMatrix2/distCoeffs2/R/T)
// reconstructs the view like fringe's rig file does, and reconstruct and info say which keys
// they used.
TEST(ReconstructCli, OneOpenCvFileWorksLikeTheRigFile) {
  constexpr double kRadiusMm = 15;
  constexpr double kMaxPointCountDifference = 0.001;
  const QuarterRigSphere sphere(kRadiusMm);
  const StereoRig& rig = sphere.rig;
  sim::RenderOptions options;
  options.sensor.supersampling = 2;
  const test::TempDir tmp;
  const auto dir = tmp / "view";
  sphere.WriteView(dir,
                   sim::SensorPoseLookingAt(rig, Eigen::Vector3d(0, 0, kRadiusMm),
                                            Eigen::Vector3d(-0.2, -0.4, 1).normalized()),
                   options);
  const std::string yml = (tmp / "stereo.yml").string();
  {
    cv::FileStorage fs(yml, cv::FileStorage::WRITE);
    const auto write_camera = [&](const std::string& suffix, const CameraModel& c) {
      fs << "cameraMatrix" + suffix
         << (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
      const auto d = c.Distortion();
      fs << "distCoeffs" + suffix << (cv::Mat_<double>(1, 5) << d[0], d[1], d[2], d[3], d[4]);
    };
    fs << "image_width" << rig.left.width << "image_height" << rig.left.height;
    write_camera("1", rig.left);
    write_camera("2", rig.right);
    const Eigen::Matrix3d r = rig.right_from_left.rotation_matrix();
    const Eigen::Vector3d t = rig.right_from_left.translation();
    cv::Mat_<double> rm(3, 3);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) rm(i, j) = r(i, j);
    }
    fs << "R" << rm << "T" << (cv::Mat_<double>(3, 1) << t.x(), t.y(), t.z());
  }
  std::string out, err;
  ASSERT_EQ(RunCli({"reconstruct", dir.string(), "--json", "--out", (tmp / "rig.ply").string()},
                   &out, &err),
            0)
      << err;
  const double with_rig = nlohmann::json::parse(out)["summary"]["points"].get<double>();
  ASSERT_EQ(RunCli({"reconstruct", dir.string(), "--opencv", yml, "--json", "--out",
                    (tmp / "opencv.ply").string()},
                   &out, &err),
            0)
      << err;
  const double with_opencv = nlohmann::json::parse(out)["summary"]["points"].get<double>();
  ASSERT_GT(with_rig, 10000);
  EXPECT_NEAR(with_opencv / with_rig, 1.0, kMaxPointCountDifference);
  for (const char* key : {"cameraMatrix1 -> ", "distCoeffs2 -> ", "R -> ", "T -> "}) {
    EXPECT_NE(err.find(key), std::string::npos) << key << " in: " << err;
  }
  ASSERT_EQ(RunCli({"info", yml}, &out, &err), 0) << err;
  EXPECT_NE(out.find("OpenCV calibration"), std::string::npos) << out;
  EXPECT_NE(out.find("cameraMatrix2 -> "), std::string::npos) << out;
}

}  // namespace
}  // namespace fringe
