// The simulator against the phase module's decoder: a rendered heterodyne scan decodes to the
// true projector coordinate (conventions of pattern generation and rendering agree).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scene.h"

namespace fringe::sim {
namespace {

TEST(PhaseDecode, RenderedHeterodyneScanDecodesToTrueProjectorColumns) {
  const StereoRig rig = ScaledRig(StereoRig::Reference(), 0.5);
  const phase::PatternScheme scheme =
      phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  RenderOptions opt;  // read noise 1.5 DN, 8 bit, gamma 2.2
  const auto patterns = phase::GeneratePatterns(scheme, opt.projector.gamma);
  const Renderer renderer(MakeSphereScene(30.0), rig, opt);
  const Rigid3d pose = SensorPoseLookingAt(rig, Eigen::Vector3d(0, 0, 20),
                                           Eigen::Vector3d(0.2, -0.3, 1).normalized());
  const ViewImages view = renderer.RenderView(pose, patterns, 0);
  phase::DecodeOptions dopt;
  dopt.noise_sigma_dn = opt.sensor.read_noise_dn;
  for (const CameraImages* cam : {&view.left, &view.right}) {
    const phase::DecodeResult decoded = phase::Decode(scheme, cam->images, dopt);
    std::vector<double> errors;
    int truth_valid = 0, wrong_order = 0;
    for (int r = 2; r < decoded.mask.rows - 2; ++r) {
      for (int c = 2; c < decoded.mask.cols - 2; ++c) {
        // Interior of lit surfaces: the 5x5 neighbourhood lit and on one object.
        bool interior = true;
        const int obj = cam->truth.object_id.at<int>(r, c);
        for (int dr = -2; dr <= 2 && interior; ++dr) {
          for (int dc = -2; dc <= 2 && interior; ++dc) {
            interior = cam->truth.valid.at<uint8_t>(r + dr, c + dc) &&
                       cam->truth.object_id.at<int>(r + dr, c + dc) == obj;
          }
        }
        if (!interior) continue;
        ++truth_valid;
        if (!decoded.mask.at<uint8_t>(r, c)) continue;
        const double err =
            decoded.absolute_phase.at<float>(r, c) - cam->truth.projector.at<cv::Vec2d>(r, c)[0];
        if (std::abs(err) > 1.0) ++wrong_order;
        errors.push_back(std::abs(err));
      }
    }
    ASSERT_GT(truth_valid, 10000);
    std::sort(errors.begin(), errors.end());
    const double median = errors[errors.size() / 2];
    RecordProperty("median_abs_error_px", std::to_string(median));
    constexpr double kMedianTolerancePx = 0.05;
    constexpr double kMinDecodedFraction = 0.95;
    constexpr double kMaxWrongOrderFraction = 1e-3;
    EXPECT_LT(median, kMedianTolerancePx);
    EXPECT_GT(errors.size(), kMinDecodedFraction * truth_valid);
    EXPECT_LT(wrong_order, kMaxWrongOrderFraction * truth_valid);
  }
}

}  // namespace
}  // namespace fringe::sim
