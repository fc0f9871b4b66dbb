#include "fringe/geometry/camera.h"

#include <gtest/gtest.h>

#include "fringe/geometry/stereo_rig.h"
#include "fringe/util/error.h"

namespace fringe {
namespace {

constexpr double kRoundTripTolPx = 1e-6;  // issue 2: project -> unproject over the whole image

void ExpectRoundTripOverImage(const CameraModel& cam) {
  double worst = 0;
  for (double v = -0.5; v <= cam.height - 0.5; v += cam.height / 37.0) {
    for (double u = -0.5; u <= cam.width - 0.5; u += cam.width / 41.0) {
      const Eigen::Vector2d px(u, v);
      const Eigen::Vector3d ray = cam.Ray(px);
      const Eigen::Vector2d back = cam.Project(ray * 437.0);
      worst = std::max(worst, (back - px).norm());
    }
  }
  EXPECT_LT(worst, kRoundTripTolPx);
}

TEST(CameraModel, ReferenceRoundTrip) { ExpectRoundTripOverImage(CameraModel::ReferenceCamera()); }

TEST(CameraModel, StrongDistortionRoundTrip) {
  CameraModel cam;
  cam.width = 640;
  cam.height = 512;
  cam.fx = cam.fy = 440;
  cam.cx = 308.8;
  cam.cy = 247.2;
  // Strong barrel distortion that is still invertible over the image (r_d(r) monotonic).
  cam.k1 = -0.35;
  cam.k2 = 0.12;
  cam.p1 = 1e-3;
  cam.p2 = -5e-4;
  ExpectRoundTripOverImage(cam);
}

TEST(CameraModel, DistortJacobianMatchesFiniteDifference) {
  const CameraModel cam = CameraModel::ReferenceCamera();
  const Eigen::Vector2d xy(0.21, -0.17);
  const double h = 1e-7;
  Eigen::Matrix2d num;
  for (int k = 0; k < 2; ++k) {
    Eigen::Vector2d d = Eigen::Vector2d::Zero();
    d[k] = h;
    num.col(k) = (cam.Distort(xy + d) - cam.Distort(xy - d)) / (2 * h);
  }
  EXPECT_LT((num - cam.DistortJacobian(xy)).norm(), 1e-7);
}

TEST(CameraModel, PrincipalPointProjectsOnAxis) {
  const CameraModel cam = CameraModel::ReferenceCamera();
  const Eigen::Vector2d px = cam.Project({0, 0, 500});
  EXPECT_NEAR(px.x(), cam.cx, 1e-12);
  EXPECT_NEAR(px.y(), cam.cy, 1e-12);
}

TEST(CameraModel, DefaultsAndReferencePassCheck) {
  EXPECT_NO_THROW(CameraModel().Check());
  EXPECT_NO_THROW(CameraModel::ReferenceCamera().Check());
  EXPECT_NO_THROW(StereoRig::Reference().Check());
  CameraModel bad;
  bad.fx = -1;
  EXPECT_THROW(bad.Check(), Error);
}

TEST(StereoRig, ReferenceGeometry) {
  const StereoRig rig = StereoRig::Reference();
  EXPECT_NEAR(rig.BaselineMm(), 200.0, 1e-9);
  // The point 500 mm ahead of the rig centre is near the image centre of both cameras.
  const Rigid3d left_from_right = rig.right_from_left.Inverse();
  const Eigen::Vector3d centre_in_left =
      0.5 * (Eigen::Vector3d::Zero() + left_from_right.translation()) + Eigen::Vector3d(0, 0, 0);
  // Optical axes converge: the right camera sees the left's optical axis point at ~510 mm
  // close to its own principal point.
  const Eigen::Vector3d on_axis_in_left(0, 0, 509.9);
  const Eigen::Vector2d px_right = rig.right.Project(rig.right_from_left * on_axis_in_left);
  EXPECT_NEAR(px_right.x(), rig.right.cx, 3.0);
  EXPECT_NEAR(px_right.y(), rig.right.cy, 3.0);
  EXPECT_GT(centre_in_left.x(), 0);  // the right camera is to the right (+x) of the left
  ASSERT_TRUE(rig.projector.has_value());
  const Eigen::Vector2d px_proj = rig.projector->Project(rig.projector_from_left * on_axis_in_left);
  EXPECT_TRUE(rig.projector->InImage(px_proj, 100));
}

}  // namespace
}  // namespace fringe
