// End to end: the demo's simulated measurement must meet the accuracy the issues ask of the
// whole chain (calibration from simulated boards, reconstruction, VDI figures), judged against
// the simulator's exact truth.
#include "fringe/pipeline/demo.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fringe/io/ply.h"
#include "fringe/util/error.h"
#include "fringe_test.h"

namespace fringe::pipeline {
namespace {

constexpr double kMaxFocalErrorPct = 0.01;    // issue 5: focal error <= 0.01 %
constexpr double kMaxBaselineErrorMm = 0.01;  // issue 5: baseline error <= 0.01 mm
constexpr double kMaxSizeErrorMm = 0.02;      // issue 6: PS and SD within +-0.02 mm
constexpr double kMaxPartRmsMm = 0.1;         // demo part deviation (noise ~0.05 mm at 1.5 DN)
constexpr double kMinCoverage = 0.75;         // lit part pixels that produce a point

TEST(Demo, EndToEndMeetsAccuracyTargets) {
  test::TempDir dir;
  const DemoSummary s = RunDemo(DemoOptions(), dir / "demo");
  EXPECT_LT(s.focal_error_pct, kMaxFocalErrorPct);
  EXPECT_LT(s.baseline_error_mm, kMaxBaselineErrorMm);
  EXPECT_GT(s.part_coverage, kMinCoverage);
  EXPECT_LT(s.part_rms_mm, kMaxPartRmsMm);
  ASSERT_TRUE(s.sphere_ok);
  ASSERT_TRUE(s.ballbar_ok);
  ASSERT_TRUE(s.plane_ok);
  EXPECT_LT(std::abs(s.PS_mm), kMaxSizeErrorMm);
  EXPECT_LT(std::abs(s.SD_mm), kMaxSizeErrorMm);
  for (const char* f : {"report.json", "report.txt", "calibration.json", "demo_part.ply",
                        "vdi_artefacts.ply", "demo_part_deviation.png"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / "demo" / f)) << f;
  }
  const OrganizedPointCloud cloud = io::ReadOrganizedPly(dir / "demo" / "demo_part.ply");
  EXPECT_EQ(static_cast<int>(cloud.NumValid()), s.part_points);
}

TEST(Demo, BadOptionsAndUnwritableOutput) {
  DemoOptions o;
  EXPECT_NO_THROW(DemoOptions().Check());
  o.calibration_images = 2;
  EXPECT_THROW(o.Check(), Error);
  o = DemoOptions();
  o.scheme = "no-such-scheme";
  EXPECT_THROW(o.Check(), Error);
  EXPECT_THROW(RunDemo(DemoOptions(), "/nonexistent/folder/demo"), Error);
}

}  // namespace
}  // namespace fringe::pipeline
