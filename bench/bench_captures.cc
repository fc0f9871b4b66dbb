// bench_captures: the figures of issue 10 ("real captures as they come") that the tests assert
// but do not print.
//
//   Low phase gradient: the simulated view whose cameras sample the projector at 0.2-0.35
//   projector px per camera pixel (testing/low_gradient.h; gray+4, B = 80 DN, sigma 1.5 DN),
//   at the tests' quarter-size rig (320x256 cameras) and at full camera size (1280x1024 cameras,
//   512x320 projector): coverage of the eligible pixels (valid left pixels whose true surface
//   point the right camera sees as a valid pixel) and the fraction of valid left pixels the
//   left-right check rejects. With --data, the same counts on the real capture
//   slsdk-stereo-phasegray (where the one-step run direction lost 16 % of the valid left pixels
//   to the left-right check).
//   8 vs 12 bits: the simulator's demo part rendered at 8 bits and at 12 bits (16-bit images
//   holding 0..4095, read noise scaled so the signal-to-noise ratio is the same), reconstructed
//   with the full scale from the bit depth (what `fringe reconstruct --bit-depth 12` and a scan's
//   bit_depth do), and once more with the 16-bit container's full scale (65535) for the texture
//   scale that gave 2.6-3.6 instead of 34-59 before: points, coverage of the lit left pixels, mean
//   texture on the 0-255 scale over the pixels valid in both.
//
// Usage: bench_captures [--json] [--quick] [--data DIR]
//   --quick: demo part on the half-size rig, no full-size low-gradient case.
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "bench_timing.h"
#include "fringe/io/calibration_io.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/stack_io.h"
#include "fringe/sim/demo_part.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/stereo/phase_matching.h"
#include "fringe/stereo/reconstruct_view.h"
#include "fringe/testing/data.h"
#include "fringe/testing/low_gradient.h"
#include "fringe/util/timer.h"

namespace fringe {
namespace {

using nlohmann::json;

// Left-right rejections as a fraction of the valid left pixels.
double LeftRightFraction(const stereo::MatchingSummary& m) {
  return m.left_valid > 0 ? static_cast<double>(m.lr_inconsistent) / m.left_valid : 0.0;
}

json LowGradient(double camera_scale, double modulation_dn) {
  constexpr double kSigmaDn = 1.5;
  const stereo::testing::LowGradientCase c =
      stereo::testing::MakeLowGradientCase(camera_scale, modulation_dn, kSigmaDn);
  const std::vector<float> steps = stereo::testing::TruePhaseSteps(c);
  util::Timer timer;
  const stereo::MatchResult m = stereo::MatchPhase(c.rig, c.left, c.right);
  const double match_s = timer.ElapsedSeconds();
  int matched = 0;
  const int eligible = stereo::testing::EligiblePixels(c, m, &matched);
  return {{"cameras", std::to_string(c.rig.left.width) + "x" + std::to_string(c.rig.left.height)},
          {"projector",
           std::to_string(c.rig.projector->width) + "x" + std::to_string(c.rig.projector->height)},
          {"phase_step_px_p5", steps.empty() ? 0.0 : steps[steps.size() / 20]},
          {"phase_step_px_p95", steps.empty() ? 0.0 : steps[steps.size() * 19 / 20]},
          {"sigma_dn", kSigmaDn},
          {"modulation_dn", modulation_dn},
          {"left_valid", m.summary.left_valid},
          {"eligible", eligible},
          {"matched_eligible", matched},
          {"coverage_eligible", eligible > 0 ? static_cast<double>(matched) / eligible : 0.0},
          {"lr_inconsistent", m.summary.lr_inconsistent},
          {"lr_rejection_fraction", LeftRightFraction(m.summary)},
          {"points", m.summary.points},
          {"warning", m.summary.warning},
          {"match_s", match_s}};
}

// The real stereo capture: decoded left pixels, left-right rejections, points.
json RealCapture(const std::filesystem::path& data) {
  const auto dir = data / "slsdk-stereo-phasegray";
  if (data.empty() || !std::filesystem::exists(dir)) {
    return {{"skipped", "slsdk-stereo-phasegray not found (give --data DIR)"}};
  }
  const phase::PatternScheme scheme = phase::MakeScheme("slsdk-phasegray");
  const auto read = [&](const char* camera) { return phase::ReadStack(dir / camera, scheme); };
  const std::vector<cv::Mat> left = read("L"), right = read("R");
  stereo::ReconstructionOptions options;
  options.compute_normals = false;  // the matching figures only
  const stereo::ViewReconstruction rec =
      stereo::ReconstructView(io::ImportOpenCvStereo(dir / "intrinsic.yml", dir / "extrinsic.yml",
                                                     left[0].cols, left[0].rows),
                              scheme, left, right, options);
  const stereo::MatchingSummary& m = rec.summary.matching;
  return {{"left_valid", m.left_valid},
          {"lr_inconsistent", m.lr_inconsistent},
          {"lr_rejection_fraction", LeftRightFraction(m)},
          {"matched", m.points},
          {"points", rec.summary.points},
          {"warning", m.warning},
          {"match_s", rec.summary.match_s}};
}

struct BitDepthRun {
  stereo::ViewReconstruction rec;
  double coverage = 0;  // lit left pixels that give a point
};

// The demo part seen as bench_reconstruction sees it, at bit_depth bits with the same
// signal-to-noise ratio (read noise 1.5 DN of 8 bits scaled to the full scale).
sim::ViewImages RenderDemo(const StereoRig& rig, const phase::PatternScheme& scheme,
                           int bit_depth) {
  sim::RenderOptions render;
  render.sensor.bit_depth = bit_depth;
  render.sensor.read_noise_dn *= render.sensor.FullScale() / 255.0;
  const sim::Scene demo = sim::MakeDemoPart();
  Eigen::Vector3d bmin, bmax;
  demo.Bounds(&bmin, &bmax);
  const Eigen::Vector3d target(0.5 * (bmin.x() + bmax.x()), 0.5 * (bmin.y() + bmax.y()), 10);
  const Rigid3d pose =
      sim::SensorPoseLookingAt(rig, target, Eigen::Vector3d(0.2, -0.5, 1).normalized());
  const sim::Renderer renderer(demo, rig, render);
  return renderer.RenderView(pose, phase::GeneratePatterns(scheme, render.projector.gamma), 400);
}

BitDepthRun ReconstructDemo(const StereoRig& rig, const phase::PatternScheme& scheme,
                            const sim::ViewImages& view, double full_scale_dn) {
  stereo::ReconstructionOptions options;
  options.decode.full_scale_dn = full_scale_dn;  // 0: the image depth's (8-bit: 255)
  options.compute_normals = false;
  BitDepthRun run;
  run.rec = stereo::ReconstructView(rig, scheme, view.left.images, view.right.images, options);
  int lit = 0, covered = 0;
  const cv::Mat& valid = view.left.truth.valid;
  for (int r = 0; r < valid.rows; ++r) {
    for (int c = 0; c < valid.cols; ++c) {
      if (!valid.at<uint8_t>(r, c)) continue;
      ++lit;
      covered += run.rec.cloud.valid[run.rec.cloud.index(c, r)];
    }
  }
  run.coverage = lit ? static_cast<double>(covered) / lit : 0.0;
  return run;
}

// Mean texture (0-255 scale) of `a` over the pixels valid in a and b; the mean |a - b| there.
void TextureOver(const stereo::ViewReconstruction& a, const stereo::ViewReconstruction& b,
                 double* mean, double* mean_abs_diff) {
  double sum = 0, sum_diff = 0;
  int64_t n = 0;
  for (size_t i = 0; i < a.cloud.valid.size(); ++i) {
    if (!a.cloud.valid[i] || !b.cloud.valid[i]) continue;
    sum += a.cloud.cloud.intensity[i];
    sum_diff += std::abs(a.cloud.cloud.intensity[i] - b.cloud.cloud.intensity[i]);
    ++n;
  }
  *mean = n ? sum / n : 0.0;
  *mean_abs_diff = n ? sum_diff / n : 0.0;
}

json BitDepths(bool quick) {
  const StereoRig rig =
      quick ? sim::ScaledRig(StereoRig::Reference(), 0.5) : StereoRig::Reference();
  const phase::PatternScheme scheme =
      phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  const sim::ViewImages view8 = RenderDemo(rig, scheme, 8);
  const sim::ViewImages view12 = RenderDemo(rig, scheme, 12);
  const BitDepthRun r8 = ReconstructDemo(rig, scheme, view8, 0);
  const BitDepthRun r12 = ReconstructDemo(rig, scheme, view12, 4095);
  const BitDepthRun r12c = ReconstructDemo(rig, scheme, view12, 0);  // container: 65535
  json out = {{"cameras", std::to_string(rig.left.width) + "x" + std::to_string(rig.left.height)},
              {"scheme", scheme.name}};
  const auto entry = [&](const BitDepthRun& r, const BitDepthRun& ref) {
    double texture = 0, texture_diff = 0;
    TextureOver(r.rec, ref.rec, &texture, &texture_diff);
    return json{{"full_scale_dn", r.rec.summary.decode_left.full_scale_dn},
                {"points", r.rec.summary.points},
                {"coverage", r.coverage},
                {"texture_mean_0_255", texture},
                {"texture_mean_abs_diff_vs_8bit", texture_diff},
                {"noise_sigma_dn", r.rec.summary.decode_left.noise.sigma_dn},
                {"min_modulation_dn", r.rec.summary.decode_left.min_modulation_dn}};
  };
  out["bits_8"] = entry(r8, r8);
  out["bits_12"] = entry(r12, r8);
  out["bits_12_container_full_scale"] = entry(r12c, r8);
  out["points_ratio_12_over_8"] =
      r8.rec.summary.points > 0
          ? static_cast<double>(r12.rec.summary.points) / r8.rec.summary.points
          : 0.0;
  out["coverage_difference_12_minus_8"] = r12.coverage - r8.coverage;
  out["texture_difference_12_minus_8_dn"] = out["bits_12"]["texture_mean_0_255"].get<double>() -
                                            out["bits_8"]["texture_mean_0_255"].get<double>();
  return out;
}

void PrintTable(const json& j) {
  std::printf("bench_captures (issue 10)\n");
  for (const char* key : {"low_gradient_quarter_rig", "low_gradient_full_cameras"}) {
    if (!j.contains(key)) continue;
    const json& g = j.at(key);
    std::printf(
        "low gradient, %s cameras / %s projector (steps %.3f-%.3f px): coverage of eligible "
        "%.4f (%d of %d), left-right rejections %.4f of %d valid left pixels\n",
        g.at("cameras").get<std::string>().c_str(), g.at("projector").get<std::string>().c_str(),
        g.at("phase_step_px_p5").get<double>(), g.at("phase_step_px_p95").get<double>(),
        g.at("coverage_eligible").get<double>(), g.at("matched_eligible").get<int>(),
        g.at("eligible").get<int>(), g.at("lr_rejection_fraction").get<double>(),
        g.at("left_valid").get<int>());
  }
  const json& real = j.at("real_capture_slsdk");
  if (real.contains("skipped")) {
    std::printf("real capture: %s\n", real.at("skipped").get<std::string>().c_str());
  } else {
    std::printf(
        "real capture slsdk-stereo-phasegray: left-right rejections %.4f of %d valid left "
        "pixels, %d points\n",
        real.at("lr_rejection_fraction").get<double>(), real.at("left_valid").get<int>(),
        real.at("points").get<int>());
  }
  const json& b = j.at("bit_depths");
  std::printf("demo part, %s cameras: %-28s %10s %9s %9s\n",
              b.at("cameras").get<std::string>().c_str(), "", "points", "coverage", "texture");
  for (const char* key : {"bits_8", "bits_12", "bits_12_container_full_scale"}) {
    const json& e = b.at(key);
    std::printf("  %-44s %10d %9.4f %9.2f\n", key, e.at("points").get<int>(),
                e.at("coverage").get<double>(), e.at("texture_mean_0_255").get<double>());
  }
}

}  // namespace
}  // namespace fringe

int main(int argc, char** argv) {
  using namespace fringe;
  bool json_out = false, quick = false;
  std::string data_arg;
  double modulation_dn = stereo::testing::kLowGradientModulationDn;
  CLI::App app("bench_captures: issue 10's low-gradient and bit-depth figures");
  app.add_flag("--json", json_out, "Print one JSON object");
  app.add_flag("--quick", quick, "Half-size demo part, no full-size low-gradient case");
  app.add_option("--data", data_arg, "Shared data folder (default ../shared/data)");
  app.add_option("--modulation", modulation_dn,
                 "Fringe modulation of the low-gradient view, DN (default: the tests' 80)")
      ->check(CLI::Range(1.0, 127.0));
  CLI11_PARSE(app, argc, argv);
  std::filesystem::path data;
  if (auto d = util::SharedDataDir()) data = *d;
  if (!data_arg.empty()) data = data_arg;

  util::Timer total;
  const double cpu0 = bench::CpuMs();
  nlohmann::json j;
  j["low_gradient_quarter_rig"] = LowGradient(0.25, modulation_dn);
  if (!quick) j["low_gradient_full_cameras"] = LowGradient(1.0, modulation_dn);
  j["real_capture_slsdk"] = RealCapture(data);
  j["bit_depths"] = BitDepths(quick);
  j["wall_s"] = total.ElapsedSeconds();
  j["cpu_s"] = (bench::CpuMs() - cpu0) / 1e3;
  if (json_out) {
    std::cout << j.dump() << "\n";
  } else {
    PrintTable(j);
  }
  return 0;
}
