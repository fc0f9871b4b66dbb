// Real single-camera + projector capture: ../shared/data/slmaster-mono-camproj-relief (12-step +
// complementary Gray code, 1280x1024 camera, 1920x1024 projector, vertical fringes) with the
// capture tool's own camera AND projector calibration (caliInfo.yml, read by
// io/opencv_calibration.h), reconstructed in camera-projector mode with the projector's lens
// distortion (stereo/camera_projector.h). The plaque is sculpted to its edges (no flat region):
// the cloud must be plausible in points, depth range, local noise and round trip into the
// projector; and the projector's distortion must matter (the test would not notice if it were
// ignored otherwise).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "fringe/cli/run_cli_for_test.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/json.h"
#include "fringe/io/opencv_calibration.h"
#include "fringe/io/ply.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/scheme_presets.h"
#include "fringe/phase/stack_io.h"
#include "fringe/sim/board.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/projector_board.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scene.h"
#include "fringe/stereo/camera_projector.h"
#include "fringe/testing/fringe_test.h"

namespace fringe {
namespace {

// The capture's scheme (../shared/data/README.md): 12 steps on 60-px periods of the 1920 x 1024
// DLP4710, 5-bit Gray code + complementary bit, files 0.png .. 17.png; the phase is -pi at the
// start of each period as in the slsdk-phasegray preset (same tool author; checked on the data:
// with this offset the decoder repairs no fringe order). `fringe reconstruct` takes the same
// scheme as `--scheme gray+12 --width 1920 --height 1024 --period 60 --gray-bits 5
// --phase-offset -3.141592653589793 --image-names %d.png`.
phase::PatternScheme SlmasterScheme() {
  phase::SchemeParameters p;
  p.projector_width = 1920;
  p.projector_height = 1024;
  p.period_px = 60;
  p.gray_bits = 5;
  p.phase_offset_rad = -M_PI;
  p.image_names = "%d.png";
  return phase::MakePresetScheme("gray+12", p);
}

// RMS of depth minus its local mean over the valid pixels of a win x win window (pixels whose
// window is at least half valid): the local noise on a surface without a flat region.
double LocalNoiseMm(const OrganizedPointCloud& cloud, int win) {
  cv::Mat z(cloud.height, cloud.width, CV_64F, cv::Scalar(0)),
      valid(z.size(), CV_64F, cv::Scalar(0));
  for (int r = 0; r < cloud.height; ++r) {
    for (int c = 0; c < cloud.width; ++c) {
      const size_t i = cloud.index(c, r);
      if (!cloud.valid[i]) continue;
      z.at<double>(r, c) = cloud.cloud.points[i].z();
      valid.at<double>(r, c) = 1;
    }
  }
  cv::Mat sum_z, count;
  cv::boxFilter(z, sum_z, CV_64F, cv::Size(win, win), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  cv::boxFilter(valid, count, CV_64F, cv::Size(win, win), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  double ss = 0;
  int n = 0;
  for (int r = 0; r < cloud.height; ++r) {
    for (int c = 0; c < cloud.width; ++c) {
      const double k = count.at<double>(r, c);
      if (valid.at<double>(r, c) == 0 || k < 0.5 * win * win) continue;
      const double d = z.at<double>(r, c) - sum_z.at<double>(r, c) / k;
      ss += d * d;
      ++n;
    }
  }
  return n ? std::sqrt(ss / n) : 0;
}

TEST(SlmasterCameraProjector, RealReliefReconstructsPlausibly) {
  FRINGE_SHARED_DATA_OR_SKIP(dir, "slmaster-mono-camproj-relief");
  // Measured when this test was written (docs/benchmarks.md): 215,186 points, depth (1-99 %)
  // 693.3 .. 773.7 mm (the plaque is tilted), local noise 0.96 mm (median |residual| 0.31 mm:
  // a low-contrast capture, decoder noise estimate 3.0 DN, and ~1.8 mm of depth per projector
  // pixel at 0.7 m with a 110 mm baseline; the sculpted contours add the tail), round trip
  // 5e-13 px, lit coverage 0.997, projector distortion effect 2.8 mm RMS. Bounds around them.
  constexpr size_t kMinPoints = 190'000;
  constexpr double kMinDepthMm = 650, kMaxDepthMm = 820;  // the plaque ~0.7 m from the camera
  constexpr double kMaxDepthSpanMm = 120;                 // a tilted relief, not a scene
  constexpr double kMaxLocalNoiseMm = 1.3;
  constexpr double kMaxRoundTripPx = 1e-6;
  constexpr double kMinLitCoverage = 0.95;
  constexpr float kLitModulationDn = 10;  // 12-step modulation of the lit plaque (PROVENANCE)
  constexpr double kMinDistortionEffectMm = 1.5;
  const phase::PatternScheme scheme = SlmasterScheme();
  const auto images = phase::ReadStack(dir / "L", scheme);
  const StereoRig rig = io::ReadOpenCvCalibration({dir / "caliInfo.yml"}, 0, 0,
                                                  scheme.projector_width, scheme.projector_height)
                            .ToCameraProjectorRig("caliInfo.yml");
  const stereo::CameraProjectorRig cp = stereo::CameraProjectorRig::FromLeftCamera(rig);
  stereo::ReconstructionOptions options;
  options.compute_normals = false;
  const stereo::ViewReconstruction rec =
      stereo::MakeCameraProjectorReconstructor(cp, {scheme}, options).Reconstruct(images, {});
  ASSERT_TRUE(rec.summary.ok()) << rec.summary.BriefReport();
  std::cout << rec.summary.decode_left.BriefReport() << "\n"
            << rec.summary.matching.BriefReport() << "\n"
            << rec.summary.BriefReport() << "\n";
  EXPECT_EQ(rec.summary.decode_left.orders_repaired, 0);

  // The round trip computed here, independently of the reconstructor's residual: every point
  // projected into the projector lands on its decoded column.
  const phase::DecodeResult decoded = phase::Decode(scheme, images);
  const size_t points = rec.cloud.NumValid();
  std::vector<double> z;
  double worst_round_trip = 0;
  for (int r = 0; r < cp.camera.height; ++r) {
    for (int c = 0; c < cp.camera.width; ++c) {
      const size_t i = rec.cloud.index(c, r);
      if (!rec.cloud.valid[i]) continue;
      const Eigen::Vector3d& p = rec.cloud.cloud.points[i];
      z.push_back(p.z());
      const double u = cp.projector.Project(cp.projector_from_camera * p).x();
      worst_round_trip =
          std::max(worst_round_trip, std::abs(u - decoded.absolute_phase.at<float>(r, c)));
    }
  }
  ASSERT_GT(z.size(), 100u);
  std::sort(z.begin(), z.end());
  const double z_lo = z[z.size() / 100], z_hi = z[z.size() * 99 / 100];
  // Lit plaque: camera pixels whose 12-step fringe modulation reaches 10 DN (the cloth around
  // the plaque is black).
  int lit = 0, lit_with_point = 0;
  for (int r = 0; r < cp.camera.height; ++r) {
    for (int c = 0; c < cp.camera.width; ++c) {
      if (decoded.modulation.at<float>(r, c) < kLitModulationDn) continue;
      ++lit;
      lit_with_point += rec.cloud.valid[rec.cloud.index(c, r)];
    }
  }
  const double coverage = lit ? static_cast<double>(lit_with_point) / lit : 0;
  const double noise = LocalNoiseMm(rec.cloud, 15);

  // The same capture with the projector taken as a pinhole: the depth moves.
  stereo::CameraProjectorRig pinhole = cp;
  pinhole.projector.SetDistortion({0, 0, 0, 0, 0});
  const stereo::ViewReconstruction rec_pinhole =
      stereo::MakeCameraProjectorReconstructor(pinhole, {scheme}, options).Reconstruct(images, {});
  double ss = 0;
  int both = 0;
  for (size_t i = 0; i < rec.cloud.valid.size(); ++i) {
    if (!rec.cloud.valid[i] || !rec_pinhole.cloud.valid[i]) continue;
    const double d = rec.cloud.cloud.points[i].z() - rec_pinhole.cloud.cloud.points[i].z();
    ss += d * d;
    ++both;
  }
  const double distortion_effect = both ? std::sqrt(ss / both) : 0;
  std::cout << points << " points, depth " << z_lo << " .. " << z_hi
            << " mm (1-99 %), local noise (15x15) " << noise << " mm, round trip "
            << worst_round_trip << " px, lit coverage " << coverage << " of " << lit
            << " pixels; ignoring the projector's distortion moves depth by " << distortion_effect
            << " mm RMS\n";
  EXPECT_GT(points, kMinPoints);
  EXPECT_GT(z_lo, kMinDepthMm);
  EXPECT_LT(z_hi, kMaxDepthMm);
  EXPECT_LT(z_hi - z_lo, kMaxDepthSpanMm);
  EXPECT_LT(noise, kMaxLocalNoiseMm);
  EXPECT_LT(worst_round_trip, kMaxRoundTripPx);
  EXPECT_GT(coverage, kMinLitCoverage);
  EXPECT_GT(distortion_effect, kMinDistortionEffectMm);
}

// `fringe reconstruct VIEW --calib RIG` on a view with only left/ images and a rig with a
// projector picks camera-projector mode (auto) and reconstructs the simulated plane; --mode
// stereo on that view, and camera-projector mode with a rig without projector, are errors.
TEST(CameraProjectorCli, LeftOnlyViewReconstructsAgainstTheProjector) {
  constexpr double kRmsTolMm = 0.15;  // quarter-scale rig, camera-projector baseline ~102 mm
  constexpr double kMinCoverage = 0.95;
  const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.25);
  const phase::PatternScheme scheme =
      phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  sim::RenderOptions options;
  options.projector.gamma = 1.0;
  const sim::Renderer renderer(sim::MakePlaneScene(), rig, options);
  const Rigid3d pose = sim::SensorPoseLookingAt(rig, Eigen::Vector3d::Zero(),
                                                Eigen::Vector3d(0.3, 0.2, 1).normalized());
  const sim::ViewImages view = renderer.RenderView(pose, phase::GeneratePatterns(scheme));
  const test::TempDir tmp;
  const auto dir = tmp / "view";
  std::filesystem::create_directories(dir / "left");
  const auto names = scheme.ImageNames();
  for (size_t i = 0; i < names.size(); ++i) {
    io::WriteImage(dir / "left" / names[i], view.left.images[i]);
  }
  phase::WriteScheme(dir / "manifest.json", scheme);
  io::WriteRig(dir / "rig.json", rig);
  std::string out, err;
  const std::string ply = (tmp / "cloud.ply").string();
  ASSERT_EQ(cli::RunCli({"reconstruct", dir.string(), "--out", ply}, &out, &err), 0) << out << err;
  EXPECT_NE(out.find("camera-projector mode"), std::string::npos) << out;
  const OrganizedPointCloud cloud = io::ReadOrganizedPly(ply);
  ASSERT_EQ(cloud.width, rig.left.width);
  int lit = 0, compared = 0;
  double ss = 0;
  for (int r = 0; r < cloud.height; ++r) {
    for (int c = 0; c < cloud.width; ++c) {
      if (!view.left.truth.valid.at<uint8_t>(r, c)) continue;
      ++lit;
      const size_t i = cloud.index(c, r);
      if (!cloud.valid[i]) continue;
      const cv::Vec3d t = view.left.truth.points.at<cv::Vec3d>(r, c);
      ss += (cloud.cloud.points[i] - Eigen::Vector3d(t[0], t[1], t[2])).squaredNorm();
      ++compared;
    }
  }
  ASSERT_GT(compared, 0);
  EXPECT_GT(compared, kMinCoverage * lit);
  EXPECT_LT(std::sqrt(ss / compared), kRmsTolMm);

  EXPECT_EQ(cli::RunCli({"reconstruct", dir.string(), "--mode", "stereo", "--out",
                         (tmp / "s.ply").string()},
                        &out, &err),
            1);
  EXPECT_NE(err.find("left/ and right/"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(tmp / "s.ply"));
  StereoRig no_projector = rig;
  no_projector.projector.reset();
  io::WriteRig(tmp / "np.json", no_projector);
  EXPECT_EQ(cli::RunCli({"reconstruct", dir.string(), "--calib", (tmp / "np.json").string(),
                         "--out", (tmp / "np.ply").string()},
                        &out, &err),
            1);
  EXPECT_NE(err.find("no calibrated projector"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(tmp / "np.ply"));
}

// `fringe calibrate DIR --target T --out RIG` with DIR/NNN/{board.png, vertical/, horizontal/}
// (docs/scan-folder.md) calibrates the camera and the projector: the rig it writes has the
// projector close to the true one (half-resolution reference rig, 5 poses, no supersampling of
// the fringe images: a plumbing check; the accuracy is calib/projector_test.cc's and
// bench_camera_projector's).
TEST(CameraProjectorCli, CalibrateFolderWithFringeStacksCalibratesTheProjector) {
  constexpr double kFocalTolPct = 0.1;
  constexpr double kPrincipalTolPx = 1.0;
  constexpr double kTranslationTolMm = 0.3;
  const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.5);
  const CameraModel& proj = *rig.projector;
  const CalibrationTarget target = CalibrationTarget::Reference();
  const test::TempDir tmp;
  const auto dir = tmp / "calibration";
  sim::ProjectorCalibrationFolderOptions so;
  so.poses.count = 5;
  so.poses.seed = 9;
  so.fringes.supersampling = 1;
  sim::WriteProjectorCalibrationFolder(rig, target, dir, so);
  io::WriteJson(tmp / "target.json", io::TargetToJson(target));
  std::string out, err;
  const std::string rig_path = (tmp / "rig.json").string();
  ASSERT_EQ(cli::RunCli({"calibrate", dir.string(), "--target", (tmp / "target.json").string(),
                         "--out", rig_path},
                        &out, &err),
            0)
      << out << err;
  EXPECT_NE(out.find("projector calibration"), std::string::npos) << out;
  const StereoRig cal = io::ReadRig(rig_path);
  ASSERT_TRUE(cal.projector.has_value());
  EXPECT_EQ(cal.BaselineMm(), 0.0);  // camera + projector, no right camera
  EXPECT_EQ(cal.projector->width, proj.width);
  EXPECT_LT(100 * std::abs(cal.projector->fx - proj.fx) / proj.fx, kFocalTolPct);
  EXPECT_LT(std::hypot(cal.projector->cx - proj.cx, cal.projector->cy - proj.cy), kPrincipalTolPx);
  EXPECT_LT(Difference(cal.projector_from_left, rig.projector_from_left).translation_mm,
            kTranslationTolMm);
  EXPECT_TRUE(io::ReadJson(rig_path)["calibration"].contains("projector_rms_px"));
}

}  // namespace
}  // namespace fringe
