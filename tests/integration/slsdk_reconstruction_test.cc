// Real stereo capture: ../shared/data/slsdk-stereo-phasegray (4-step + complementary Gray code,
// OpenCV stereo calibration), reconstructed through the library; the cloud must be plausible.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "fringe/eval/vdi2634.h"
#include "fringe/io/calibration_io.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/stack_io.h"
#include "fringe/stereo/reconstruct_view.h"
#include "fringe/testing/fringe_test.h"

namespace fringe {
namespace {

TEST(SlsdkReconstruction, RealCaptureGivesAPlausibleCloud) {
  FRINGE_SHARED_DATA_OR_SKIP(dir, "slsdk-stereo-phasegray");
  // Figures measured when this test was written: 1.47 M points from 2.32 M decoded left pixels,
  // depths 1081-1389 mm (1 %-99 %), plane RMS 0.73 mm on the machined part's front face (the
  // fringe period is 60 projector pixels and 1 pixel of disparity is ~0.9 mm at 1.1 m here).
  constexpr size_t kMinPoints = 1'000'000;
  constexpr double kMinDepthMm = 1000, kMaxDepthMm = 1450;
  constexpr double kMaxPlaneRmsMm = 1.0;
  const phase::PatternScheme scheme = phase::MakeScheme("slsdk-phasegray");
  const auto left = phase::ReadStack(dir / "L", scheme);
  const auto right = phase::ReadStack(dir / "R", scheme);
  const StereoRig rig = io::ImportOpenCvStereo(dir / "intrinsic.yml", dir / "extrinsic.yml",
                                               left.at(0).cols, left.at(0).rows);
  stereo::ReconstructionOptions options;
  options.compute_normals = false;  // not needed here; keeps the test quick
  const stereo::ViewReconstruction rec = stereo::ReconstructView(rig, scheme, left, right, options);
  ASSERT_TRUE(rec.summary.ok()) << rec.summary.BriefReport();
  EXPECT_GT(rec.cloud.NumValid(), kMinPoints) << rec.summary.matching.BriefReport();

  std::vector<double> z;
  for (size_t i = 0; i < rec.cloud.valid.size(); ++i) {
    if (rec.cloud.valid[i]) z.push_back(rec.cloud.cloud.points[i].z());
  }
  std::sort(z.begin(), z.end());
  EXPECT_GT(z[z.size() / 100], kMinDepthMm);
  EXPECT_LT(z[z.size() * 99 / 100], kMaxDepthMm);

  // A flat face of the machined part (left image pixels 360..599 x 720..809).
  std::vector<Eigen::Vector3d> face;
  for (int r = 720; r < 810; ++r) {
    for (int c = 360; c < 600; ++c) {
      const size_t i = rec.cloud.index(c, r);
      if (rec.cloud.valid[i]) face.push_back(rec.cloud.cloud.points[i]);
    }
  }
  EXPECT_GT(face.size(), 15000u);
  const eval::PlaneFit plane = eval::FitPlane(face);
  ASSERT_TRUE(plane.ok);
  EXPECT_LT(plane.rms_mm, kMaxPlaneRmsMm);
  EXPECT_GT(std::abs(plane.normal.z()), 0.95);  // facing the cameras
}

}  // namespace
}  // namespace fringe
