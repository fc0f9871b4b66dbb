#include "fringe/sim/renderer.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>

#include "fringe/sim/poses.h"
#include "fringe/sim/scene.h"
#include "fringe/testing/sim.h"
#include "fringe/util/error.h"

namespace fringe::sim {
namespace {

// A quarter-resolution reference rig: 320x256 cameras, 320x200 projector, same geometry.
StereoRig SmallRig() { return ScaledRig(StereoRig::Reference(), 0.25); }

RenderOptions IdealOptions() {
  RenderOptions o;
  o.sensor.noise = false;
  o.sensor.float_output = true;
  o.projector.gamma = 1.0;
  o.projector.black_level = 0.0;
  return o;
}

Rigid3d TopView(const StereoRig& rig, const Eigen::Vector3d& target = Eigen::Vector3d::Zero()) {
  return SensorPoseLookingAt(rig, target, Eigen::Vector3d(0.1, -0.2, 1.0).normalized());
}

// Midpoint triangulation of two rays (camera centres and unit directions, same frame).
Eigen::Vector3d Triangulate(const Eigen::Vector3d& c1, const Eigen::Vector3d& d1,
                            const Eigen::Vector3d& c2, const Eigen::Vector3d& d2) {
  const Eigen::Vector3d w = c1 - c2;
  const double a = d1.dot(d1), b = d1.dot(d2), c = d2.dot(d2), d = d1.dot(w), e = d2.dot(w);
  const double den = a * c - b * b;
  const double s = (b * e - c * d) / den, t = (a * e - b * d) / den;
  return 0.5 * ((c1 + s * d1) + (c2 + t * d2));
}

TEST(RenderOptions, DefaultsPassCheck) {
  EXPECT_NO_THROW(RenderOptions().Check());
  EXPECT_NO_THROW(SensorOptions().Check());
  EXPECT_NO_THROW(ProjectorOptions().Check());
  RenderOptions bad;
  bad.sensor.bit_depth = 10;
  EXPECT_THROW(bad.Check(), Error);
  bad = RenderOptions();
  bad.projector.gamma = 0;
  EXPECT_THROW(bad.Check(), Error);
}

TEST(Renderer, RejectsBadInput) {
  StereoRig no_projector = SmallRig();
  no_projector.projector.reset();
  EXPECT_THROW(Renderer(MakePlaneScene(), no_projector), Error);
  EXPECT_THROW(Renderer(Scene(), SmallRig()), Error);
  const Renderer renderer(MakePlaneScene(), SmallRig());
  const cv::Mat wrong_size(10, 10, CV_8U, cv::Scalar(255));
  EXPECT_THROW(renderer.RenderView(TopView(SmallRig()), {wrong_size}), Error);
}

// Ideal N-step decoding of noise-free rendered images recovers the true projector coordinate.
TEST(Renderer, IdealPhaseDecodingRecoversProjectorCoordinate) {
  const StereoRig rig = SmallRig();
  const Renderer renderer(MakeSphereScene(40.0), rig, IdealOptions());
  const double period = 16.0;
  const int steps = 4;
  const auto patterns =
      testing::SinusoidPatterns(rig.projector->width, rig.projector->height, period, steps);
  const ViewImages view = renderer.RenderView(TopView(rig, Eigen::Vector3d(0, 0, 40)), patterns, 0);
  constexpr double kTolerancePx = 0.01;
  for (const CameraImages* cam : {&view.left, &view.right}) {
    const CameraTruth& truth = cam->truth;
    int checked = 0;
    double max_err = 0;
    for (int r = 3; r < truth.valid.rows - 3; ++r) {
      for (int c = 3; c < truth.valid.cols - 3; ++c) {
        // Interior of a smooth surface: the whole 7x7 neighbourhood lit, on the same object.
        bool interior = true;
        const int obj = truth.object_id.at<int>(r, c);
        for (int dr = -3; dr <= 3 && interior; ++dr) {
          for (int dc = -3; dc <= 3 && interior; ++dc) {
            interior = truth.valid.at<uint8_t>(r + dr, c + dc) &&
                       truth.object_id.at<int>(r + dr, c + dc) == obj;
          }
        }
        if (!interior) continue;
        const double true_x = truth.projector.at<cv::Vec2d>(r, c)[0];
        const double phi = testing::WrappedPhase(cam->images, r, c);
        double x = phi / (2 * M_PI) * period;
        x += period * std::round((true_x - x) / period);  // fringe order from the truth
        max_err = std::max(max_err, std::abs(x - true_x));
        ++checked;
      }
    }
    RecordProperty("max_projector_error_px", std::to_string(max_err));
    EXPECT_GT(checked, 5000);
    EXPECT_LT(max_err, kTolerancePx);
  }
}

// Truth is consistent with the rig: triangulating true correspondences gives the true points.
TEST(Renderer, TrueCorrespondencesTriangulateToTruePoints) {
  const StereoRig rig = SmallRig();
  RenderOptions opt;
  const Renderer renderer(MakeSphereScene(30.0), rig, opt);
  const ViewImages view = renderer.RenderView(TopView(rig, Eigen::Vector3d(0, 0, 30)), {}, 0);
  const Rigid3d left_from_right = rig.right_from_left.Inverse();
  constexpr double kToleranceMm = 1e-6;
  int checked = 0;
  double max_err = 0;
  for (int r = 0; r < rig.left.height; r += 3) {
    for (int c = 0; c < rig.left.width; c += 3) {
      const double depth = view.left.truth.depth.at<double>(r, c);
      if (!std::isfinite(depth)) continue;
      const cv::Vec3d p = view.left.truth.points.at<cv::Vec3d>(r, c);
      const Eigen::Vector3d p_left(p[0], p[1], p[2]);
      EXPECT_NEAR(p_left.z(), depth, 1e-12);
      const Eigen::Vector3d p_right = rig.right_from_left * p_left;
      if (p_right.z() <= 0) continue;
      const Eigen::Vector2d right_px = rig.right.Project(p_right);
      const Eigen::Vector3d d_left = rig.left.Ray(Eigen::Vector2d(c, r));
      const Eigen::Vector3d d_right = left_from_right.RotateDirection(rig.right.Ray(right_px));
      const Eigen::Vector3d x =
          Triangulate(Eigen::Vector3d::Zero(), d_left, left_from_right.translation(), d_right);
      max_err = std::max(max_err, (x - p_left).norm());
      ++checked;
    }
  }
  RecordProperty("max_triangulation_error_mm", std::to_string(max_err));
  EXPECT_GT(checked, 1000);
  EXPECT_LT(max_err, kToleranceMm);
}

TEST(Renderer, SphereTruthLiesOnTheExactSphere) {
  const StereoRig rig = SmallRig();
  const Scene scene = MakeSphereScene(30.0, /*with_plate=*/false);
  const Renderer renderer(scene, rig, RenderOptions());
  const Rigid3d world_from_sensor = TopView(rig);
  const ViewImages view = renderer.RenderView(world_from_sensor, {}, 0);
  const Sphere sphere = *scene.objects()[0].sphere;
  int checked = 0;
  for (int r = 0; r < rig.left.height; ++r) {
    for (int c = 0; c < rig.left.width; ++c) {
      const cv::Vec3d p = view.left.truth.points.at<cv::Vec3d>(r, c);
      if (!std::isfinite(p[0])) continue;
      const Eigen::Vector3d p_world = world_from_sensor * Eigen::Vector3d(p[0], p[1], p[2]);
      EXPECT_NEAR((p_world - sphere.centre).norm(), sphere.radius_mm, 1e-9);
      const cv::Vec3d n = view.left.truth.normals.at<cv::Vec3d>(r, c);
      const Eigen::Vector3d n_world =
          world_from_sensor.RotateDirection(Eigen::Vector3d(n[0], n[1], n[2]));
      EXPECT_NEAR(n_world.dot((p_world - sphere.centre).normalized()), 1.0, 1e-9);
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
}

// Projector shadows: shadowed surface receives only ambient light.
TEST(Renderer, ShadowedPixelsGetOnlyAmbientLight) {
  const StereoRig rig = SmallRig();
  RenderOptions opt = IdealOptions();
  opt.sensor.supersampling = 1;
  const Renderer renderer(MakeSphereScene(40.0), rig, opt);
  const cv::Mat white(rig.projector->height, rig.projector->width, CV_32F, cv::Scalar(1.0));
  const ViewImages view = renderer.RenderView(TopView(rig, Eigen::Vector3d(0, 0, 40)), {white});
  const CameraTruth& truth = view.left.truth;
  const double plate_albedo = renderer.scene().FindObject("base_plate")->albedo;
  const int plate = 1;
  int shadowed = 0;
  for (int r = 0; r < truth.valid.rows; ++r) {
    for (int c = 0; c < truth.valid.cols; ++c) {
      if (truth.object_id.at<int>(r, c) != plate || truth.valid.at<uint8_t>(r, c)) continue;
      const cv::Vec2d uv = truth.projector.at<cv::Vec2d>(r, c);
      if (!rig.projector->InImage(Eigen::Vector2d(uv[0], uv[1]), 1)) continue;
      ++shadowed;
      const double expected = opt.sensor.exposure * 255 * plate_albedo * opt.projector.ambient;
      EXPECT_NEAR(view.left.images[0].at<float>(r, c), expected, 1e-3);
    }
  }
  EXPECT_GT(shadowed, 100);  // the sphere casts a shadow on the plate
}

// Same seed, same images, whatever the number of threads; another seed, other noise.
TEST(Renderer, DeterministicAndIndependentOfThreadCount) {
  const StereoRig rig = ScaledRig(StereoRig::Reference(), 0.125);
  RenderOptions opt;
  opt.sensor.shot_noise = true;
  const auto patterns =
      testing::SinusoidPatterns(rig.projector->width, rig.projector->height, 12.0, 3);
  const Renderer renderer(MakeSphereScene(40.0), rig, opt);
  const Rigid3d pose = TopView(rig, Eigen::Vector3d(0, 0, 40));
  const ViewImages a = renderer.RenderView(pose, patterns, 3);
  ViewImages b;
  {
    tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
    b = renderer.RenderView(pose, patterns, 3);
  }
  for (size_t k = 0; k < patterns.size(); ++k) {
    EXPECT_EQ(cv::norm(a.left.images[k], b.left.images[k], cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(a.right.images[k], b.right.images[k], cv::NORM_INF), 0.0);
  }
  const ViewImages other_view = renderer.RenderView(pose, patterns, 4);
  EXPECT_GT(cv::norm(a.left.images[0], other_view.left.images[0], cv::NORM_L1), 0.0);
}

TEST(Renderer, QuantisesAndSaturates) {
  const StereoRig rig = ScaledRig(StereoRig::Reference(), 0.125);
  RenderOptions opt;
  opt.sensor.exposure = 5.0;  // heavily overexposed
  opt.sensor.bit_depth = 12;
  const Renderer renderer(MakePlaneScene(), rig, opt);
  const cv::Mat white(rig.projector->height, rig.projector->width, CV_8U, cv::Scalar(255));
  const ViewImages view = renderer.RenderView(TopView(rig), {white});
  ASSERT_EQ(view.left.images[0].type(), CV_16U);
  double min_v, max_v;
  cv::minMaxLoc(view.left.images[0], &min_v, &max_v);
  EXPECT_EQ(max_v, 4095.0);
}

TEST(Poses, SensorLooksAtTheTarget) {
  const StereoRig rig = StereoRig::Reference();
  const Eigen::Vector3d target(10, 20, 30);
  const Rigid3d pose = SensorPoseLookingAt(rig, target, Eigen::Vector3d::UnitZ());
  EXPECT_LT((pose * WorkingPoint(rig) - target).norm(), 1e-9);
  OrbitOptions opt;
  opt.views = 6;
  for (bool turntable : {false, true}) {
    opt.turntable = turntable;
    const auto poses = OrbitPoses(rig, target, opt);
    ASSERT_EQ(poses.size(), 6u);
    for (const Rigid3d& p : poses) {
      // The working point lies above the table near the target.
      const Eigen::Vector3d w = p * WorkingPoint(rig);
      EXPECT_LT((w - target).norm(), 30.0);
      EXPECT_GT(p.translation().z(), target.z() + 100);
    }
  }
}

}  // namespace
}  // namespace fringe::sim

namespace fringe::sim {
namespace {

// The sensor's read noise has the configured sigma and no bias; shot noise adds its share.
TEST(ApplySensor, NoiseHasTheConfiguredSigma) {
  const cv::Mat radiance(200, 300, CV_32F, cv::Scalar(0.4));
  SensorOptions opt;
  opt.float_output = true;
  opt.read_noise_dn = 2.0;
  const cv::Mat noisy = ApplySensor(radiance, opt, 7);
  cv::Scalar mean, stddev;
  cv::meanStdDev(noisy, mean, stddev);
  const double expected_dn = opt.exposure * 255 * 0.4;
  EXPECT_NEAR(mean[0], expected_dn, 0.05);
  EXPECT_NEAR(stddev[0], 2.0, 0.05);
  opt.shot_noise = true;
  cv::meanStdDev(ApplySensor(radiance, opt, 7), mean, stddev);
  EXPECT_NEAR(stddev[0], std::sqrt(4.0 + expected_dn / opt.electrons_per_dn), 0.05);
  opt.noise = false;
  opt.float_output = false;
  const cv::Mat clean = ApplySensor(radiance, opt, 7);
  EXPECT_EQ(clean.type(), CV_8U);
  EXPECT_EQ(clean.at<uint8_t>(0, 0), static_cast<uint8_t>(std::lround(expected_dn)));
}

}  // namespace
}  // namespace fringe::sim

namespace fringe::sim {
namespace {

// Peak-to-peak of the rendered fringe over the central image region.
double FringeContrast(const ProjectorOptions& projector, const SensorOptions& sensor) {
  const StereoRig rig = ScaledRig(StereoRig::Reference(), 0.25);
  RenderOptions opt;
  opt.projector = projector;
  opt.sensor = sensor;
  opt.truth = false;
  const Renderer renderer(MakePlaneScene(), rig, opt);
  const auto patterns =
      testing::SinusoidPatterns(rig.projector->width, rig.projector->height, 6.0, 3);
  const ViewImages view = renderer.RenderView(
      SensorPoseLookingAt(rig, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()), {patterns[0]});
  const cv::Mat centre = view.left.images[0](cv::Rect(100, 100, 120, 56));
  double lo, hi;
  cv::minMaxLoc(centre, &lo, &hi);
  return hi - lo;
}

TEST(Renderer, ProjectorAndCameraDefocusBlurTheFringes) {
  ProjectorOptions projector;
  projector.gamma = 1.0;
  SensorOptions sensor;
  sensor.noise = false;
  sensor.float_output = true;
  const double sharp = FringeContrast(projector, sensor);
  ProjectorOptions blurred_projector = projector;
  blurred_projector.defocus_sigma_px = 2.0;
  SensorOptions blurred_sensor = sensor;
  blurred_sensor.defocus_sigma_px = 2.0;
  EXPECT_GT(sharp, 50.0);
  // A Gaussian of sigma s attenuates a sinusoid of period P by exp(-2 (pi s / P)^2): ~0.004 for
  // the 6 px projector period; ~0.3 in the camera, where the period is ~8 px. The peak-to-peak
  // measure also holds the slow shading variation over the window (~10% of the contrast).
  EXPECT_LT(FringeContrast(blurred_projector, sensor), 0.2 * sharp);
  EXPECT_LT(FringeContrast(projector, blurred_sensor), 0.45 * sharp);
}

}  // namespace
}  // namespace fringe::sim
