// bench_phase: fringe analysis accuracy and speed, against OpenCV contrib structured_light
// (SinusoidalPattern PSP + HistogramPhaseUnwrapping, and FTP) on the same images, in one run.
//
//   build/bench/bench_phase            readable table
//   build/bench/bench_phase --json     one JSON object
//   options: --data DIR (../shared/data, for the real capture), --repeats N (timing runs)
//
// Synthetic images have known projector coordinates (phase::RenderSyntheticStack): Gaussian
// camera noise sigma_I, modulation B, background 128 DN. "Pure Gaussian" accuracy figures use
// 16-bit images scaled by 256 (same SNR, negligible rounding) so the noise limit
// sqrt(2/N) sigma_I / B is exact.
//
// One function per case below, each returning its JSON keys; main merges them and prints the
// object or the table. Accuracy measures are in phase_accuracy.h, timing in bench_timing.h.
#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/phase_unwrapping.hpp>
#include <opencv2/structured_light.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "fringe/io/image_io.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/gamma.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/synthetic.h"
#include "fringe/testing/data.h"
#include "fringe/util/memory.h"
#ifdef FRINGE_BENCH_HAS_SIM
#include "fringe/geometry/stereo_rig.h"
#include "fringe/sim/demo_part.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#endif
#include "bench_timing.h"
#include "phase_accuracy.h"

namespace {

using namespace fringe;
using namespace fringe::phase;
using bench::Accuracy;
using bench::CpuMsPerRun;
using bench::Evaluate;
using bench::PeerAccuracy;
using bench::TimeMs;
using nlohmann::json;

const cv::Size kCamera(1280, 1024);

// 1. Wrapped-phase noise against the limit sqrt(2/N) sigma / B (pure Gaussian noise).
json WrappedPhaseNoise() {
  json out;
  const double b = 60, sigma = 2;
  const std::pair<const char*, const char*> cases[] = {{"crb_ratio_3step", "heterodyne-3x3"},
                                                       {"crb_ratio_4step", "heterodyne-4x3"},
                                                       {"crb_ratio_4_3_3", "thesis-4+3+3"}};
  uint64_t seed = 11;
  for (const auto& [key, name] : cases) {
    const PatternScheme s = MakeScheme(name);
    const cv::Mat u = LinearProjectorMap(s, kCamera);
    const auto images = RenderSyntheticStack(s, u, bench::Gaussian16(b, sigma, seed++));
    DecodeOptions opt;
    opt.noise_sigma_dn = sigma * 256;
    const DecodeResult r = Decode(s, images, opt);
    const Accuracy a = Evaluate(s, r, u);
    const double limit = WrappedPhaseSigma(s, 0, sigma, b);
    out[key] = a.wrapped_rms_rad / limit;
    out[std::string(key) + "_rms_rad"] = a.wrapped_rms_rad;
    out[std::string(key) + "_limit_rad"] = limit;
    // Absolute phase of multi-frequency schemes against the whole stack's limit (issue 10),
    // and the finest set alone (whole_stack off) against the finest set's limit.
    if (s.phase_sets.size() > 1) {
      const std::string suffix = std::string(key).substr(std::string("crb_ratio_").size());
      const std::string k =
          std::string("abs_phase_crb_ratio_") + (suffix == "4step"   ? "heterodyne_4x3"
                                                 : suffix == "3step" ? "heterodyne_3x3"
                                                                     : suffix);
      DecodeOptions finest = opt;
      finest.whole_stack = false;
      const double rms = bench::AbsoluteRmsPx(s, r, u);
      const double rms_finest = bench::AbsoluteRmsPx(s, Decode(s, images, finest), u);
      const double lim = AbsolutePhaseSigmaPx(s, sigma, b, true);
      const double lim_finest = AbsolutePhaseSigmaPx(s, sigma, b, false);
      out[k] = rms / lim;
      out[k + "_rms_px"] = rms;
      out[k + "_limit_px"] = lim;
      out[k + "_finest_set_rms_px"] = rms_finest;
      out[k + "_finest_set_ratio"] = rms_finest / lim_finest;
    }
  }
  out["crb_b_dn"] = b;
  out["crb_sigma_dn"] = sigma;
  return out;
}

// 2. Wrong fringe orders at B = 40 DN, sigma = 2 DN (8-bit), spatial check off (raw).
json WrongOrders() {
  json out;
  for (const auto& [key, name] :
       {std::pair<const char*, const char*>{"", "heterodyne-4x3"}, {"_4_3_3", "thesis-4+3+3"}}) {
    const PatternScheme s = MakeScheme(name);
    const cv::Mat u = LinearProjectorMap(s, kCamera);
    SyntheticStackOptions so;
    so.modulation_dn = 40;
    so.noise_sigma_dn = 2;
    so.seed = 21;
    DecodeOptions opt;
    opt.spatial_check_fraction = 0;
    const Accuracy a = Evaluate(s, Decode(s, RenderSyntheticStack(s, u, so), opt), u);
    out[std::string("wrong_order_fraction") + key] = a.wrong_order_fraction;
    out[std::string("wrong_order_valid_fraction") + key] = a.valid_fraction;
    out[std::string("wrong_order_predicted") + key] = OrderErrorProbability(s, 2.0, 40.0);
  }
  out["wrong_order_b_dn"] = 40;
  out["wrong_order_sigma_dn"] = 2;
  return out;
}

// 2b. Every temporal unwrapping method (issue 27): raw fringe-order error rate at B = 30 DN and
// sigma = 1, 2, 4, 8 DN (no modulation threshold, no spatial repair) against the noise model;
// the noise tolerance (largest sigma with an order-error rate <= 1e-5) measured by bisection
// over sigma on 1.3 M pixels vs predicted by OrderErrorProbability; decode time per image.
// The projector map covers the middle 80 % of the span, so a coarsest period equal to the span
// (hierarchical 1 period, SLStudio's cue) is inside its margin, as the prediction assumes.
struct MethodCase {
  const char* key;
  PatternScheme scheme;
};

std::vector<MethodCase> MethodCases() {
  const auto sets = [](const std::vector<double>& periods, int steps, Unwrapping u) {
    PatternScheme s;
    s.projector_width = 1280;
    s.projector_height = 800;
    for (const double p : periods) {
      PhaseShiftSet set;
      set.period_px = p;
      set.steps = steps;
      s.phase_sets.push_back(set);
    }
    s.unwrapping = u;
    s.Check();
    return s;
  };
  PatternScheme sl = sets({1280.0 / 16, 1280.0}, 3, Unwrapping::kHierarchical);
  for (auto& set : sl.phase_sets) {
    set.shifts_rad = {0.0, -2 * M_PI / 3, -4 * M_PI / 3};
    set.phase_offset_rad = -M_PI / set.period_px;
  }
  return {{"heterodyne_4x3", MakeScheme("heterodyne-4x3")},
          {"gray_4", MakeScheme("gray+4")},
          {"hierarchical_1_8_64",
           sets({1280.0 / 64, 1280.0 / 8, 1280.0}, 4, Unwrapping::kHierarchical)},
          {"hierarchical_slstudio_2x3", sl},
          {"number_theoretic_37_32",
           sets({1280.0 / 37, 1280.0 / 32}, 4, Unwrapping::kNumberTheoretic)}};
}

// Fraction of pixels whose decoded coordinate is off by more than a quarter of the finest
// period, and the fraction rejected (order ambiguous or no key).
std::pair<double, double> OrderErrorRate(const PatternScheme& s, const cv::Mat& u, double b_dn,
                                         double sigma_dn, uint64_t seed) {
  SyntheticStackOptions so;
  so.bit_depth = 16;  // no 8-bit rounding at small sigma: 16-bit images scaled by 256
  so.background_dn = 128 * 256;
  so.modulation_dn = b_dn * 256;
  so.noise_sigma_dn = sigma_dn * 256;
  so.seed = seed;
  DecodeOptions opt;
  opt.spatial_check_fraction = 0;
  opt.min_modulation_dn = 1;
  opt.min_modulation_ratio = 0;
  opt.noise_sigma_dn = sigma_dn * 256;
  const DecodeResult r = Decode(s, RenderSyntheticStack(s, u, so), opt);
  int64_t wrong = 0, rejected = 0;
  const double limit = 0.25 * s.phase_sets[0].period_px;
  for (int y = 0; y < u.rows; ++y) {
    for (int x = 0; x < u.cols; ++x) {
      if (!r.mask.at<uint8_t>(y, x)) {
        ++rejected;
      } else if (std::fabs(r.absolute_phase.at<float>(y, x) - u.at<float>(y, x)) > limit) {
        ++wrong;
      }
    }
  }
  const double n = static_cast<double>(u.total());
  return {wrong / n, rejected / n};
}

json UnwrappingMethods(int repeats) {
  json out;
  constexpr double kB = 30.0, kTarget = 1e-5;
  out["unwrap_b_dn"] = kB;
  out["unwrap_target_order_error"] = kTarget;
  for (const MethodCase& m : MethodCases()) {
    const PatternScheme& s = m.scheme;
    const std::string k = std::string("unwrap_") + m.key;
    // Middle 80 % of the span across the image, with a slight shear (LinearProjectorMap's).
    cv::Mat u = LinearProjectorMap(s, kCamera);
    u = 0.1 * s.Span() + 0.8 * u;
    out[k + "_method"] = UnwrappingName(s.Method());
    out[k + "_images"] = s.NumImages();
    for (const double sigma : {1.0, 2.0, 4.0, 8.0}) {
      const auto [rate, rejected] = OrderErrorRate(s, u, kB, sigma, 71);
      const std::string ks = k + "_sigma_" + std::to_string(static_cast<int>(sigma));
      out[ks + "_order_error"] = rate;
      out[ks + "_rejected"] = rejected;
      out[ks + "_order_error_predicted"] = OrderErrorProbability(s, sigma, kB);
    }
    // Predicted tolerance: OrderErrorProbability rises with sigma; bisection on log sigma.
    double lo = 0.05, hi = 100;
    for (int i = 0; i < 60; ++i) {
      const double mid = std::sqrt(lo * hi);
      (OrderErrorProbability(s, mid, kB) <= kTarget ? lo : hi) = mid;
    }
    out[k + "_tolerance_sigma_predicted_dn"] = lo;
    // Measured: the same bisection on the measured rate (8 steps: within 2^(1/16) ~ 4 %
    // of the predicted bracket [pred / 2, pred * 2]).
    double mlo = lo / 2, mhi = lo * 2;
    if (OrderErrorRate(s, u, kB, mlo, 72).first > kTarget) mhi = mlo, mlo = lo / 8;
    for (int i = 0; i < 8; ++i) {
      const double mid = std::sqrt(mlo * mhi);
      (OrderErrorRate(s, u, kB, mid, 73 + i).first <= kTarget ? mlo : mhi) = mid;
    }
    out[k + "_tolerance_sigma_measured_dn"] = mlo;
    out[k + "_tolerance_measured_over_predicted"] = mlo / lo;
    // Decode time on 8-bit images at B 60, sigma 2 (the default options: whole stack, spatial
    // check), median of `repeats`.
    SyntheticStackOptions so;
    so.modulation_dn = 60;
    so.noise_sigma_dn = 2;
    so.seed = 74;
    const auto images = RenderSyntheticStack(s, u, so);
    DecodeOptions opt;
    opt.noise_sigma_dn = 2;
    DecodeResult r;
    const double ms = TimeMs(repeats, [&] { Decode(s, images, opt, &r); });
    out[k + "_decode_ms"] = ms;
    out[k + "_decode_ms_per_image"] = ms / s.NumImages();
  }
  return out;
}

// 3. Gamma 2.2: gamma-free, uncompensated, pre-compensated patterns, decoder table.
json GammaCases() {
  json out;
  for (const auto& [prefix, name] :
       {std::pair<const char*, const char*>{"gamma_", "heterodyne-4x3"},
        {"gamma_3step_", "heterodyne-3x3"}}) {
    const PatternScheme s = MakeScheme(name);
    const cv::Mat u = LinearProjectorMap(s, kCamera);
    SyntheticStackOptions so;
    so.modulation_dn = 90;
    so.noise_sigma_dn = 1;
    so.seed = 31;
    const double free_rms =
        Evaluate(s, Decode(s, RenderSyntheticStack(s, u, so)), u).wrapped_rms_rad;
    so.projector_gamma = 2.2;
    const auto raw = RenderSyntheticStack(s, u, so);
    DecodeOptions table;
    table.projector_gamma = 2.2;
    const double raw_rms = Evaluate(s, Decode(s, raw), u).wrapped_rms_rad;
    const double table_rms = Evaluate(s, Decode(s, raw, table), u).wrapped_rms_rad;
    so.precompensate_gamma = 2.2;
    const double pre_rms =
        Evaluate(s, Decode(s, RenderSyntheticStack(s, u, so)), u).wrapped_rms_rad;
    out[std::string(prefix) + "free_rms_rad"] = free_rms;
    out[std::string(prefix) + "uncompensated_rms_rad"] = raw_rms;
    out[std::string(prefix) + "compensated_rms_rad"] = pre_rms;
    out[std::string(prefix) + "table_rms_rad"] = table_rms;
    if (std::string(prefix) == "gamma_") {
      const GammaEstimate est = EstimateGamma(s, raw);
      out["gamma_estimated"] = est.success ? est.gamma : -1.0;
    }
  }
  return out;
}

// Our decoder's time and accuracy on the scene (bumps and a step): heterodyne-4x3 (12 images),
// all threads, one thread and process CPU time. Sets *ours_ms (the speed-ups' reference).
json OursOnScene(const SyntheticStackOptions& so, int repeats, double* ours_ms) {
  json out;
  const PatternScheme s12 = MakeScheme("heterodyne-4x3");
  const cv::Mat u12 = bench::SceneMap(s12, kCamera);
  const auto stack12 = RenderSyntheticStack(s12, u12, so);
  DecodeResult r;
  *ours_ms = TimeMs(repeats, [&] { Decode(s12, stack12, DecodeOptions(), &r); });
  const Accuracy a12 = Evaluate(s12, r, u12);
  double ours_1t_ms = 0;
  {
    tbb::task_arena one(1);
    DecodeResult r1;
    one.execute([&] {
      ours_1t_ms =
          TimeMs(std::max(3, repeats / 3), [&] { Decode(s12, stack12, DecodeOptions(), &r1); });
    });
  }
  out["ours_decode_ms"] = *ours_ms;
  // Every output map bit and the repaired pixels: a speed-up that leaves this unchanged decodes
  // identically (the summary's figures are in the JSON beside it).
  bench::Digest digest;
  for (const cv::Mat* m :
       {&r.absolute_phase, &r.wrapped_phase, &r.modulation, &r.background, &r.mask, &r.reason}) {
    for (int row = 0; row < m->rows; ++row) digest.Add(m->ptr(row), m->cols * m->elemSize());
  }
  for (const cv::Point& p : r.repaired_px) digest.Add(&p, sizeof(p));
  out["ours_decode_digest"] = digest.Hex();
  out["ours_valid"] = r.summary.valid;
  out["ours_min_modulation_dn"] = r.summary.min_modulation_dn;
  out["ours_noise_sigma_dn"] = r.summary.noise.sigma_dn;
  out["ours_noise_estimate_ms"] = TimeMs(repeats, [&] { EstimateNoise(s12, stack12, 255); });
  // The memory bound: the stack's bytes over this machine's copy bandwidth (the decoder must
  // read every image once), and with the outputs it writes (phase, wrapped phase, modulation,
  // background: 4 bytes each; mask, reason: 1 byte each per pixel).
  const double gb_s = bench::CopyBandwidthGbPerS();
  const double read_bytes = static_cast<double>(stack12.size()) * kCamera.area();
  const double written_bytes = 18.0 * kCamera.area();
  out["copy_bandwidth_gb_s"] = gb_s;
  out["decode_bytes_read"] = read_bytes;
  out["decode_bytes_written"] = written_bytes;
  out["decode_memory_bound_ms"] = read_bytes / gb_s * 1e-6;
  out["decode_memory_bound_read_write_ms"] = (read_bytes + written_bytes) / gb_s * 1e-6;
  out["ours_decode_over_memory_bound"] = *ours_ms / (read_bytes / gb_s * 1e-6);
  out["ours_decode_cpu_ms"] =
      CpuMsPerRun(repeats, [&] { Decode(s12, stack12, DecodeOptions(), &r); });
  out["ours_decode_1thread_ms"] = ours_1t_ms;
  out["ours_rms_4step_rad"] = a12.wrapped_rms_rad;
  out["ours_valid_fraction"] = a12.valid_fraction;
  out["ours_wrong_order_fraction"] = a12.wrong_order_fraction;
  return out;
}

// OpenCV's SinusoidalPattern parameters for the first three images of a 3-step scheme.
cv::Ptr<cv::structured_light::SinusoidalPattern::Params> OpenCvParams(const PatternScheme& s9) {
  auto params = cv::makePtr<cv::structured_light::SinusoidalPattern::Params>();
  params->width = kCamera.width;
  params->height = kCamera.height;
  params->nbrOfPeriods = static_cast<int>(std::round(s9.Span() / s9.phase_sets[0].period_px));
  params->shiftValue = static_cast<float>(2 * M_PI / 3);
  params->horizontal = false;
  params->setMarkers = false;
  return params;
}

// OpenCV PSP and FTP (+ histogram unwrapping) on the first three images of the 3-step stack.
json OpenCvOnScene(const PatternScheme& s9, const cv::Mat& u9, const std::vector<cv::Mat>& stack9,
                   int repeats) {
  json out;
  auto params = OpenCvParams(s9);
  std::vector<cv::Mat> three(stack9.begin(), stack9.begin() + 3);
  for (int method : {cv::structured_light::PSP, cv::structured_light::FTP}) {
    params->methodId = method;
    auto sp = cv::structured_light::SinusoidalPattern::create(params);
    cv::Mat wrapped, unwrapped, shadow;
    const int runs = std::max(1, repeats / 5);
    const double wrap_ms = TimeMs(runs, [&] {
      wrapped.release();
      shadow.release();
      sp->computePhaseMap(three, wrapped, shadow);
    });
    const double cpu_ms = CpuMsPerRun(runs, [&] {
      wrapped.release();
      shadow.release();
      sp->computePhaseMap(three, wrapped, shadow);
      unwrapped.release();
      sp->unwrapPhaseMap(wrapped, unwrapped, kCamera, shadow);
    });
    const double unwrap_ms = TimeMs(runs, [&] {
      unwrapped.release();
      sp->unwrapPhaseMap(wrapped, unwrapped, kCamera, shadow);
    });
    const PeerAccuracy pa = bench::EvaluatePeer(wrapped, unwrapped, shadow, s9, u9);
    const std::string key = method == cv::structured_light::PSP ? "opencv_psp" : "opencv_ftp";
    out[key + "_ms"] = wrap_ms + unwrap_ms;
    out[key + "_cpu_ms"] = cpu_ms;
    out[key + "_wrap_ms"] = wrap_ms;
    out[key + "_rms_rad"] = pa.wrapped_rms_rad;
    out[key + "_central_rms_rad"] = pa.central_rms_rad;
    out[key + "_unwrapped_rms_rad"] = pa.unwrapped_rms_rad;
    out[key + "_unwrap_error_fraction"] = pa.unwrap_error_fraction;
    out[key + "_valid_fraction"] = pa.valid_fraction;
  }
  return out;
}

// OpenCV's band-pass filtering smooths: on a flat plane it beats the per-pixel limit.
json FlatPlane(const PatternScheme& s9, const SyntheticStackOptions& so) {
  json out;
  const cv::Mat flat = LinearProjectorMap(s9, kCamera);
  const auto stack_flat = RenderSyntheticStack(s9, flat, so);
  auto params = OpenCvParams(s9);
  params->methodId = cv::structured_light::PSP;
  auto sp = cv::structured_light::SinusoidalPattern::create(params);
  cv::Mat wrapped, shadow;
  std::vector<cv::Mat> three_flat(stack_flat.begin(), stack_flat.begin() + 3);
  sp->computePhaseMap(three_flat, wrapped, shadow);
  out["opencv_psp_flat_rms_rad"] =
      bench::EvaluatePeer(wrapped, cv::Mat(), shadow, s9, flat).wrapped_rms_rad;
  out["ours_flat_rms_rad"] = Evaluate(s9, Decode(s9, stack_flat), flat).wrapped_rms_rad;
  return out;
}

// 4. Speed and accuracy against OpenCV on the same images (scene with bumps and a step).
json SpeedVsOpenCv(int repeats) {
  const double b = 60, sigma = 2;
  SyntheticStackOptions so;
  so.modulation_dn = b;
  so.noise_sigma_dn = sigma;
  so.seed = 41;
  double ours_ms = 0;
  json out = OursOnScene(so, repeats, &ours_ms);

  // 3-step stack: its first three images are what OpenCV PSP gets.
  const PatternScheme s9 = MakeScheme("heterodyne-3x3");
  const cv::Mat u9 = bench::SceneMap(s9, kCamera);
  const auto stack9 = RenderSyntheticStack(s9, u9, so);
  DecodeResult r9;
  const double ours9_ms = TimeMs(repeats, [&] { Decode(s9, stack9, DecodeOptions(), &r9); });
  const Accuracy a9 = Evaluate(s9, r9, u9);
  out["ours_decode_9_images_ms"] = ours9_ms;
  out["ours_rms_rad"] = a9.wrapped_rms_rad;  // same 3 images as OpenCV PSP
  out["ours_abs_valid_fraction_3x3"] = a9.valid_fraction;

  out.update(OpenCvOnScene(s9, u9, stack9, repeats));
  out["speedup_vs_opencv_psp"] = out["opencv_psp_ms"].get<double>() / ours_ms;
  out["speedup_vs_opencv_ftp"] = out["opencv_ftp_ms"].get<double>() / ours_ms;
  out["cpu_speedup_vs_opencv_psp"] =
      out["opencv_psp_cpu_ms"].get<double>() / out["ours_decode_cpu_ms"].get<double>();
  out["speed_b_dn"] = b;
  out["speed_sigma_dn"] = sigma;
  out.update(FlatPlane(s9, so));
  return out;
}

#ifdef FRINGE_BENCH_HAS_SIM
// Absolute phase of a simulated camera against the renderer's truth: valid fraction of the lit
// pixels, RMS of the right orders, wrong orders overall and away from depth edges.
json CompareWithTruth(const PatternScheme& s, const sim::CameraImages& cam, const DecodeResult& r) {
  json out;
  int64_t truth_valid = 0, both = 0, wrong = 0, interior = 0, wrong_interior = 0;
  double sum = 0;
  const double p0 = s.phase_sets[0].period_px;
  // Interior: the 3x3 truth neighbourhood is lit and continuous (no projector jump > P/4), so
  // the supersampled pixel does not mix two surfaces.
  auto is_interior = [&](int y, int x) {
    if (y < 1 || x < 1 || y + 1 >= r.mask.rows || x + 1 >= r.mask.cols) return false;
    const double c = cam.truth.projector.at<cv::Vec2d>(y, x)[0];
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (!cam.truth.valid.at<uint8_t>(y + dy, x + dx)) return false;
        if (std::fabs(cam.truth.projector.at<cv::Vec2d>(y + dy, x + dx)[0] - c) > 0.25 * p0) {
          return false;
        }
      }
    }
    return true;
  };
  for (int y = 0; y < r.mask.rows; ++y) {
    for (int x = 0; x < r.mask.cols; ++x) {
      if (!cam.truth.valid.at<uint8_t>(y, x)) continue;
      ++truth_valid;
      if (!r.mask.at<uint8_t>(y, x)) continue;
      ++both;
      const bool in = is_interior(y, x);
      interior += in;
      const double e =
          r.absolute_phase.at<float>(y, x) - cam.truth.projector.at<cv::Vec2d>(y, x)[0];
      if (std::fabs(e) > 0.25 * p0) {
        ++wrong;
        wrong_interior += in;
      } else {
        sum += e * e;
      }
    }
  }
  out["sim_wrong_order_fraction_interior"] =
      static_cast<double>(wrong_interior) / std::max<int64_t>(interior, 1);
  out["sim_valid_fraction_of_lit"] = static_cast<double>(both) / std::max<int64_t>(truth_valid, 1);
  out["sim_abs_rms_px"] = std::sqrt(sum / std::max<int64_t>(both - wrong, 1));
  out["sim_wrong_order_fraction"] = static_cast<double>(wrong) / std::max<int64_t>(both, 1);
  return out;
}

// 4b. The virtual scanner: the demo part seen by the reference rig's left camera, projector
// gamma 2.2 with pre-compensated heterodyne-4x3 patterns, read noise 1.5 DN, 3x3 supersampling.
json VirtualScanner(int repeats) {
  const StereoRig rig = StereoRig::Reference();
  const sim::Scene scene = sim::MakeDemoPart();
  sim::RenderOptions ro;
  ro.sensor.seed = 51;
  const sim::Renderer renderer(scene, rig, ro);
  const Rigid3d pose = sim::SensorPoseLookingAt(rig, Eigen::Vector3d::Zero(),
                                                Eigen::Vector3d(0.2, -0.3, 1).normalized());
  const PatternScheme s = MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  const auto view = renderer.RenderView(pose, GeneratePatterns(s, ro.projector.gamma), 0);
  DecodeResult r;
  const double ms = TimeMs(std::max(3, repeats / 3), [&] { Decode(s, view.left.images, {}, &r); });
  json out = CompareWithTruth(s, view.left, r);
  out["sim_decode_ms"] = ms;
  out["sim_jump_fraction"] = JumpFraction(r.absolute_phase, r.mask, s.phase_sets[0].period_px);
  return out;
}
#endif

// 5. Real capture (4-step + complementary Gray code).
json RealCapture(const std::filesystem::path& data, int repeats) {
  json out;
  const auto dir = data / "slsdk-stereo-phasegray";
  if (!data.empty() && std::filesystem::exists(dir)) {
    const PatternScheme s = MakeScheme("slsdk-phasegray");
    for (const std::string cam : {"L", "R"}) {
      std::vector<cv::Mat> images;
      for (const auto& n : s.ImageNames()) images.push_back(io::ReadGrayImage(dir / cam / n));
      DecodeResult r;
      const double ms = TimeMs(std::max(1, repeats / 3), [&] { Decode(s, images, {}, &r); });
      const std::string k = "real_" + std::string(cam == "L" ? "left" : "right");
      out[k + "_valid_fraction"] = r.summary.ValidFraction();
      out[k + "_jump_fraction"] =
          JumpFraction(r.absolute_phase, r.mask, s.phase_sets[0].period_px, 0.25);
      out[k + "_orders_repaired"] = r.summary.orders_repaired;
      out[k + "_decode_ms"] = ms;
    }
  } else {
    out["real_skipped"] = "slsdk-stereo-phasegray not found";
  }
  return out;
}

// The human-readable table of the JSON object.
void PrintTable(const json& out) {
  auto num = [&](const char* k) {
    if (!out.contains(k)) return std::string("-");
    if (!out.at(k).is_number_float()) return out.at(k).dump();
    std::ostringstream os;
    os << std::setprecision(4) << out.at(k).get<double>();
    return os.str();
  };
  std::cout << "bench_phase (" << kCamera.width << "x" << kCamera.height << ", "
            << out.at("threads") << " threads)\n\n"
            << "wrapped-phase RMS / noise limit sqrt(2/N) sigma/B (B 60, sigma 2, Gaussian)\n"
            << "  3-step " << num("crb_ratio_3step") << "   4-step " << num("crb_ratio_4step")
            << "   4+3+3 " << num("crb_ratio_4_3_3") << "   (target <= 1.05)\n"
            << "absolute-phase RMS / whole-stack limit (inverse-variance combination of all sets)\n"
            << "  heterodyne-4x3 " << num("abs_phase_crb_ratio_heterodyne_4x3") << " ("
            << num("abs_phase_crb_ratio_heterodyne_4x3_rms_px") << " px; finest set alone "
            << num("abs_phase_crb_ratio_heterodyne_4x3_finest_set_rms_px") << " px)   4+3+3 "
            << num("abs_phase_crb_ratio_4_3_3") << " (" << num("abs_phase_crb_ratio_4_3_3_rms_px")
            << " px; finest set alone " << num("abs_phase_crb_ratio_4_3_3_finest_set_rms_px")
            << " px)   (target <= 1.05)\n\n"
            << "wrong fringe orders at B 40, sigma 2 (no spatial repair)\n"
            << "  heterodyne-4x3 " << num("wrong_order_fraction") << " (predicted "
            << num("wrong_order_predicted") << ")   thesis-4+3+3 "
            << num("wrong_order_fraction_4_3_3") << "   (target <= 1e-5)\n\n"
            << "temporal unwrapping methods (B " << num("unwrap_b_dn")
            << " DN; raw order-error rate at sigma 1/2/4/8 DN; noise tolerance at 1e-5)\n";
  for (const MethodCase& m : MethodCases()) {
    const std::string k = std::string("unwrap_") + m.key;
    std::cout << "  " << std::left << std::setw(28) << m.key << std::right;
    for (const char* sg : {"1", "2", "4", "8"}) {
      std::cout << " " << num((k + "_sigma_" + sg + "_order_error").c_str());
    }
    std::cout << "  tolerance " << num((k + "_tolerance_sigma_measured_dn").c_str())
              << " DN (predicted " << num((k + "_tolerance_sigma_predicted_dn").c_str()) << ")  "
              << num((k + "_decode_ms_per_image").c_str()) << " ms/image\n";
  }
  std::cout << "\n"
            << "gamma 2.2, wrapped RMS rad (4-step / 3-step)\n"
            << "  gamma-free      " << num("gamma_free_rms_rad") << " / "
            << num("gamma_3step_free_rms_rad") << "\n"
            << "  uncompensated   " << num("gamma_uncompensated_rms_rad") << " / "
            << num("gamma_3step_uncompensated_rms_rad") << "\n"
            << "  pre-compensated " << num("gamma_compensated_rms_rad") << " / "
            << num("gamma_3step_compensated_rms_rad") << "\n"
            << "  decoder table   " << num("gamma_table_rms_rad") << " / "
            << num("gamma_3step_table_rms_rad") << "\n"
            << "  estimated gamma " << num("gamma_estimated") << "\n\n"
            << "decode one camera (scene with bumps and a step, B 60, sigma 2)\n"
            << "                              time ms      wrapped RMS rad\n"
            << "  ours heterodyne-4x3 (12)    " << num("ours_decode_ms") << "   "
            << num("ours_rms_4step_rad") << "  (1 thread " << num("ours_decode_1thread_ms")
            << " ms; CPU " << num("ours_decode_cpu_ms") << " ms)\n"
            << "  ours heterodyne-3x3 (9)     " << num("ours_decode_9_images_ms") << "   "
            << num("ours_rms_rad") << "  (same 3 images as PSP)\n"
            << "  OpenCV PSP + unwrap (3)     " << num("opencv_psp_ms") << "   "
            << num("opencv_psp_rms_rad") << "  (central " << num("opencv_psp_central_rms_rad")
            << "; unwrap errors " << num("opencv_psp_unwrap_error_fraction") << "; CPU "
            << num("opencv_psp_cpu_ms") << " ms)\n"
            << "  OpenCV FTP + unwrap (1)     " << num("opencv_ftp_ms") << "   "
            << num("opencv_ftp_rms_rad") << "\n"
            << "  speed-up vs PSP " << num("speedup_vs_opencv_psp") << "x (CPU time "
            << num("cpu_speedup_vs_opencv_psp") << "x), vs FTP " << num("speedup_vs_opencv_ftp")
            << "x\n"
            << "  memory bound: " << num("decode_memory_bound_ms") << " ms to read the stack ("
            << num("decode_memory_bound_read_write_ms") << " ms with the outputs) at "
            << num("copy_bandwidth_gb_s") << " GB/s copy bandwidth; decode / bound "
            << num("ours_decode_over_memory_bound") << "; digest " << num("ours_decode_digest")
            << "\n"
            << "  flat plane: OpenCV PSP " << num("opencv_psp_flat_rms_rad") << ", ours "
            << num("ours_flat_rms_rad") << " rad (band-pass smoothing vs per pixel)\n\n"
            << "virtual scanner (demo part, left camera, gamma 2.2 pre-compensated, 1.5 DN)\n"
            << "  valid of lit " << num("sim_valid_fraction_of_lit") << "  abs RMS px "
            << num("sim_abs_rms_px") << "  wrong orders " << num("sim_wrong_order_fraction")
            << " (interior " << num("sim_wrong_order_fraction_interior") << ")"
            << "  jumps " << num("sim_jump_fraction") << "  " << num("sim_decode_ms") << " ms\n\n"
            << "real capture slsdk-stereo-phasegray (2048x1536, gray+4)\n"
            << "  left  valid " << num("real_left_valid_fraction") << "  jumps "
            << num("real_left_jump_fraction") << "  " << num("real_left_decode_ms") << " ms\n"
            << "  right valid " << num("real_right_valid_fraction") << "  jumps "
            << num("real_right_jump_fraction") << "  " << num("real_right_decode_ms") << " ms\n";
}

}  // namespace

int main(int argc, char** argv) {
  fringe::util::UseTransparentHugePages(argv);  // as the fringe program does
  bool as_json = false;
  int repeats = 15;
  std::filesystem::path data;
  if (auto d = util::SharedDataDir()) data = *d;
  CLI::App app("bench_phase: fringe analysis accuracy and speed, against OpenCV structured_light");
  app.add_flag("--json", as_json, "Print one JSON object");
  app.add_option("--repeats", repeats, "Timing repeats (median)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  bool unwrapping_only = false;
  app.add_flag("--unwrapping-only", unwrapping_only,
               "Only the temporal unwrapping methods (issue 27 figures)");
  bool speed_only = false;
  app.add_flag(
      "--quick", speed_only,
      "Only the decoding speed against OpenCV and the memory bound (scripts/bench-check.sh)");
  std::string data_arg;
  app.add_option("--data", data_arg, "Shared data folder (default ../shared/data)");
  CLI11_PARSE(app, argc, argv);
  if (!data_arg.empty()) data = data_arg;
  json out;
  out["camera"] = {{"width", kCamera.width}, {"height", kCamera.height}};
  out["threads"] = tbb::this_task_arena::max_concurrency();
  {
    double load[1] = {0};
    if (getloadavg(load, 1) == 1) out["load_average_at_start"] = load[0];
  }
  if (unwrapping_only) {
    out.update(UnwrappingMethods(repeats));
    std::cout << out.dump() << "\n";
    return 0;
  }
  if (speed_only) {
    out.update(SpeedVsOpenCv(repeats));
    if (as_json) {
      std::cout << out.dump() << "\n";
    } else {
      PrintTable(out);
    }
    return 0;
  }
  out.update(WrappedPhaseNoise());
  out.update(WrongOrders());
  out.update(UnwrappingMethods(repeats));
  out.update(GammaCases());
  out.update(SpeedVsOpenCv(repeats));
#ifdef FRINGE_BENCH_HAS_SIM
  out.update(VirtualScanner(repeats));
#endif
  out.update(RealCapture(data, repeats));
  if (as_json) {
    std::cout << out.dump() << "\n";
  } else {
    PrintTable(out);
  }
  return 0;
}
