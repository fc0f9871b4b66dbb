#include "fringe/registration/align_to_mesh.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fringe/sim/demo_part.h"
#include "fringe/testing/registration_views.h"

namespace fringe::registration {
namespace {

// The figure for best fit to a reference: a view moved by 2 deg / 2 mm comes back to
// within these of its true pose.
constexpr double kAlignRotTolDeg = 0.005;
constexpr double kAlignCentroidTolMm = 0.01;

TEST(AlignToMesh, SimulatedViewMovedByTwoDegreesAndTwoMillimetresComesBack) {
  // Full resolution: at half resolution (640x512) the edge points' bias is at about the
  // tolerance (0.0058 deg after the decoder's noise estimate stopped rejecting low-modulation
  // pixels), at a quarter above it.
  const StereoRig rig = StereoRig::Reference();
  sim::DemoPartOptions part;
  part.grid_mm = 0.25;
  const sim::Scene scene = sim::MakeDemoPart(part);
  const Rigid3d truth = sim::OrbitPoses(rig, {0, 0, 25})[1];  // mesh(world)_from_sensor
  const PointCloud cloud = testing::SimulateView(rig, scene, truth, 1).rec.cloud.Compact();
  ASSERT_GT(cloud.size(), 10000u);
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : cloud.points) c += p;
  c /= static_cast<double>(cloud.size());
  const Eigen::Vector3d cw = truth * c;
  const Rigid3d turn =
      Rigid3d::FromAxisAngle(Eigen::Vector3d(0.3, -1, 0.6).normalized(), 2 * M_PI / 180);
  const Rigid3d start = Rigid3d(turn.rotation(), cw - turn.RotateDirection(cw) +
                                                     2 * Eigen::Vector3d(1, 1, -0.5).normalized()) *
                        truth;
  const MeshIndex mesh(scene.CombinedMesh());
  MeshAlignOptions o;
  o.initial_threshold_mm = 8;  // 2 deg at the ~100 mm lever plus 2 mm
  const MeshAlignResult r = AlignToMesh(cloud, mesh, start, o);
  ASSERT_NE(r.status, IcpStatus::kNoOverlap) << r.BriefReport();
  const double rot_deg = (truth.rotation().inverse() * r.mesh_from_cloud.rotation())
                             .angularDistance(Eigen::Quaterniond::Identity()) *
                         180 / M_PI;
  EXPECT_LT(rot_deg, kAlignRotTolDeg) << r.BriefReport();
  EXPECT_LT((r.mesh_from_cloud * c - cw).norm(), kAlignCentroidTolMm) << r.BriefReport();
  EXPECT_LT(r.rms_mm, 0.1);  // the reconstruction's noise, not a misfit
  ASSERT_EQ(r.levels.size(), o.points_per_level.size());
  EXPECT_LT(r.levels.back().threshold_end_mm, o.initial_threshold_mm / 10);
}

TEST(AlignToMesh, EmptyCloudIsNoOverlap) {
  const MeshIndex mesh(sim::MakeBoxMesh({0, 0, 0}, {10, 10, 10}));
  const MeshAlignResult r = AlignToMesh(PointCloud(), mesh, Rigid3d());
  EXPECT_EQ(r.status, IcpStatus::kNoOverlap);
  EXPECT_NE(r.message.find("finite points"), std::string::npos);
}

}  // namespace
}  // namespace fringe::registration
