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
#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ctime>
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
#include "fringe/util/test_data.h"
#ifdef FRINGE_BENCH_HAS_SIM
#include "fringe/geometry/stereo_rig.h"
#include "fringe/sim/demo_part.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#endif
#include "fringe/util/timer.h"

namespace {

using namespace fringe;
using namespace fringe::phase;
using nlohmann::json;

const cv::Size kCamera(1280, 1024);

double WrapPi(double x) { return x - 2 * M_PI * std::round(x / (2 * M_PI)); }

// True wrapped phase of set 0 at projector coordinate u (docs/formats.md).
double TruePsi(const PatternScheme& s, double u) {
  const auto& set = s.phase_sets[0];
  return 2 * M_PI * (u + 0.5) / set.period_px + set.phase_offset_rad;
}

struct Accuracy {
  double wrapped_rms_rad = 0;
  double wrong_order_fraction = 0;
  double valid_fraction = 0;
  int64_t wrong = 0, valid = 0;
};

Accuracy Evaluate(const PatternScheme& s, const DecodeResult& r, const cv::Mat& u_true,
                  const cv::Mat& region = cv::Mat()) {
  Accuracy a;
  double sum = 0;
  int64_t considered = 0;
  const double p = s.phase_sets[0].period_px;
  for (int y = 0; y < u_true.rows; ++y) {
    for (int x = 0; x < u_true.cols; ++x) {
      if (!region.empty() && !region.at<uint8_t>(y, x)) continue;
      ++considered;
      if (!r.mask.at<uint8_t>(y, x)) continue;
      const double u = u_true.at<float>(y, x);
      const double e = WrapPi(r.wrapped_phase.at<float>(y, x) - TruePsi(s, u));
      sum += e * e;
      ++a.valid;
      if (std::fabs(r.absolute_phase.at<float>(y, x) - u) > 0.25 * p) ++a.wrong;
    }
  }
  a.wrapped_rms_rad = std::sqrt(sum / std::max<int64_t>(a.valid, 1));
  a.wrong_order_fraction = static_cast<double>(a.wrong) / std::max<int64_t>(a.valid, 1);
  a.valid_fraction = static_cast<double>(a.valid) / std::max<int64_t>(considered, 1);
  return a;
}

// RMS (projector px) of the absolute phase against the truth over valid pixels with the right
// order (|error| < P/4).
double AbsoluteRmsPx(const PatternScheme& s, const DecodeResult& r, const cv::Mat& u_true) {
  const double p = s.phase_sets[0].period_px;
  double sum = 0;
  int64_t n = 0;
  for (int y = 0; y < u_true.rows; ++y) {
    for (int x = 0; x < u_true.cols; ++x) {
      if (!r.mask.at<uint8_t>(y, x)) continue;
      const double e = r.absolute_phase.at<float>(y, x) - u_true.at<float>(y, x);
      if (std::fabs(e) > 0.25 * p) continue;
      sum += e * e;
      ++n;
    }
  }
  return std::sqrt(sum / std::max<int64_t>(n, 1));
}

// A scene: a tilted plane with smooth bumps and a raised block (a depth step shifts the
// projector coordinate by 7.3 px), so that spatial filtering is not free.
cv::Mat SceneMap(const PatternScheme& s, cv::Size size) {
  cv::Mat u = LinearProjectorMap(s, size);
  const double span = s.Span();
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      double du = 0;
      const double bx[3] = {0.25, 0.5, 0.75}, by[3] = {0.3, 0.7, 0.4}, sg[3] = {40, 25, 12};
      for (int k = 0; k < 3; ++k) {
        const double dx = x - bx[k] * size.width, dy = y - by[k] * size.height;
        du += 6.0 * std::exp(-(dx * dx + dy * dy) / (2 * sg[k] * sg[k]));
      }
      if (x > 0.6 * size.width && x < 0.85 * size.width && y > 0.15 * size.height &&
          y < 0.45 * size.height) {
        du += 7.3;
      }
      float& v = u.at<float>(y, x);
      v = static_cast<float>(std::clamp(v * 0.97 + 0.01 * span + du, 0.0, span - 1.0));
    }
  }
  return u;
}

SyntheticStackOptions Gaussian16(double b, double sigma, uint64_t seed) {
  SyntheticStackOptions o;
  o.bit_depth = 16;
  o.background_dn = 128 * 256.0;
  o.modulation_dn = b * 256.0;
  o.noise_sigma_dn = sigma * 256.0;
  o.quantize_patterns = false;
  o.seed = seed;
  return o;
}

double Median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double CpuMs() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

// Process CPU time per run (all threads): the work, independent of other load on the machine.
template <typename F>
double CpuMsPerRun(int repeats, F&& f) {
  f();
  const double c0 = CpuMs();
  for (int i = 0; i < repeats; ++i) f();
  return (CpuMs() - c0) / repeats;
}

template <typename F>
double TimeMs(int repeats, F&& f) {
  std::vector<double> t;
  f();  // warm-up
  for (int i = 0; i < repeats; ++i) {
    util::Timer timer;
    f();
    t.push_back(timer.ElapsedMs());
  }
  return Median(t);
}

// OpenCV's phase follows its own pattern convention (sin, its shift sign): align it to the
// truth with the best sign and constant offset before measuring, which favours OpenCV.
struct PeerAccuracy {
  double wrapped_rms_rad = 0;
  double unwrapped_rms_rad = 0;  // after removing the best constant (spatial unwrap is relative)
  double unwrap_error_fraction = 0;  // pixels off by more than pi after that
  double valid_fraction = 0;
  double central_rms_rad = 0;  // wrapped, inner 80 % x 80 % of the image (no DFT border effects)
};

PeerAccuracy EvaluatePeer(const cv::Mat& wrapped, const cv::Mat& unwrapped, const cv::Mat& mask,
                          const PatternScheme& s, const cv::Mat& u_true) {
  PeerAccuracy a;
  const double p = s.phase_sets[0].period_px;
  double best = 1e9;
  for (int sign : {1, -1}) {
    double c = 0, sn = 0;
    int64_t n = 0;
    for (int y = 0; y < u_true.rows; y += 2) {
      for (int x = 0; x < u_true.cols; x += 2) {
        if (!mask.at<uint8_t>(y, x)) continue;
        const double d = sign * wrapped.at<float>(y, x) - TruePsi(s, u_true.at<float>(y, x));
        c += std::cos(d);
        sn += std::sin(d);
        ++n;
      }
    }
    const double offset = std::atan2(sn, c);
    double sum = 0, sum_central = 0;
    int64_t valid = 0, central = 0;
    for (int y = 0; y < u_true.rows; ++y) {
      for (int x = 0; x < u_true.cols; ++x) {
        if (!mask.at<uint8_t>(y, x)) continue;
        const double e =
            WrapPi(sign * wrapped.at<float>(y, x) - TruePsi(s, u_true.at<float>(y, x)) - offset);
        sum += e * e;
        ++valid;
        if (x > u_true.cols / 10 && x < u_true.cols * 9 / 10 && y > u_true.rows / 10 &&
            y < u_true.rows * 9 / 10) {
          sum_central += e * e;
          ++central;
        }
      }
    }
    const double rms = std::sqrt(sum / std::max<int64_t>(valid, 1));
    if (rms < best) {
      best = rms;
      a.wrapped_rms_rad = rms;
      a.central_rms_rad = std::sqrt(sum_central / std::max<int64_t>(central, 1));
      a.valid_fraction = static_cast<double>(valid) / u_true.total();
      if (!unwrapped.empty()) {
        std::vector<double> d;
        for (int y = 0; y < u_true.rows; ++y) {
          for (int x = 0; x < u_true.cols; ++x) {
            if (!mask.at<uint8_t>(y, x)) continue;
            d.push_back(sign * unwrapped.at<float>(y, x) -
                        2 * M_PI * (u_true.at<float>(y, x) + 0.5) / p);
          }
        }
        const double med = Median(d);
        double su = 0;
        int64_t bad = 0;
        for (double v : d) {
          const double e = v - med;
          if (std::fabs(e) > M_PI) {
            ++bad;
          } else {
            su += e * e;
          }
        }
        a.unwrapped_rms_rad = std::sqrt(su / std::max<int64_t>(d.size() - bad, 1));
        a.unwrap_error_fraction = static_cast<double>(bad) / std::max<size_t>(d.size(), 1);
      }
    }
  }
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  bool as_json = false;
  int repeats = 15;
  std::filesystem::path data;
  if (auto d = util::SharedDataDir()) data = *d;
  CLI::App app("bench_phase: fringe analysis accuracy and speed, against OpenCV structured_light");
  app.add_flag("--json", as_json, "Print one JSON object");
  app.add_option("--repeats", repeats, "Timing repeats (median)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
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

  // 1. Wrapped-phase noise against the limit sqrt(2/N) sigma / B (pure Gaussian noise).
  {
    const double b = 60, sigma = 2;
    const std::pair<const char*, const char*> cases[] = {{"crb_ratio_3step", "heterodyne-3x3"},
                                                         {"crb_ratio_4step", "heterodyne-4x3"},
                                                         {"crb_ratio_4_3_3", "thesis-4+3+3"}};
    uint64_t seed = 11;
    for (const auto& [key, name] : cases) {
      const PatternScheme s = MakeScheme(name);
      const cv::Mat u = LinearProjectorMap(s, kCamera);
      const auto images = RenderSyntheticStack(s, u, Gaussian16(b, sigma, seed++));
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
        const double rms = AbsoluteRmsPx(s, r, u);
        const double rms_finest = AbsoluteRmsPx(s, Decode(s, images, finest), u);
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
  }

  // 2. Wrong fringe orders at B = 40 DN, sigma = 2 DN (8-bit), spatial check off (raw).
  {
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
  }

  // 3. Gamma 2.2: gamma-free, uncompensated, pre-compensated patterns, decoder table.
  {
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
  }

  // 4. Speed and accuracy against OpenCV on the same images (scene with bumps and a step).
  {
    const double b = 60, sigma = 2;
    SyntheticStackOptions so;
    so.modulation_dn = b;
    so.noise_sigma_dn = sigma;
    so.seed = 41;
    const PatternScheme s12 = MakeScheme("heterodyne-4x3");
    const cv::Mat u12 = SceneMap(s12, kCamera);
    const auto stack12 = RenderSyntheticStack(s12, u12, so);
    DecodeResult r;
    const double ours_ms = TimeMs(repeats, [&] { Decode(s12, stack12, DecodeOptions(), &r); });
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
    out["ours_decode_ms"] = ours_ms;
    out["ours_decode_cpu_ms"] =
        CpuMsPerRun(repeats, [&] { Decode(s12, stack12, DecodeOptions(), &r); });
    out["ours_decode_1thread_ms"] = ours_1t_ms;
    out["ours_rms_4step_rad"] = a12.wrapped_rms_rad;
    out["ours_valid_fraction"] = a12.valid_fraction;
    out["ours_wrong_order_fraction"] = a12.wrong_order_fraction;

    // 3-step stack: its first three images are what OpenCV PSP gets.
    const PatternScheme s9 = MakeScheme("heterodyne-3x3");
    const cv::Mat u9 = SceneMap(s9, kCamera);
    const auto stack9 = RenderSyntheticStack(s9, u9, so);
    DecodeResult r9;
    const double ours9_ms = TimeMs(repeats, [&] { Decode(s9, stack9, DecodeOptions(), &r9); });
    const Accuracy a9 = Evaluate(s9, r9, u9);
    out["ours_decode_9_images_ms"] = ours9_ms;
    out["ours_rms_rad"] = a9.wrapped_rms_rad;  // same 3 images as OpenCV PSP
    out["ours_abs_valid_fraction_3x3"] = a9.valid_fraction;

    auto params = cv::makePtr<cv::structured_light::SinusoidalPattern::Params>();
    params->width = kCamera.width;
    params->height = kCamera.height;
    params->nbrOfPeriods = static_cast<int>(std::round(s9.Span() / s9.phase_sets[0].period_px));
    params->shiftValue = static_cast<float>(2 * M_PI / 3);
    params->horizontal = false;
    params->setMarkers = false;
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
      const PeerAccuracy pa = EvaluatePeer(wrapped, unwrapped, shadow, s9, u9);
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
    out["speedup_vs_opencv_psp"] = out["opencv_psp_ms"].get<double>() / ours_ms;
    out["speedup_vs_opencv_ftp"] = out["opencv_ftp_ms"].get<double>() / ours_ms;
    out["cpu_speedup_vs_opencv_psp"] =
        out["opencv_psp_cpu_ms"].get<double>() / out["ours_decode_cpu_ms"].get<double>();
    out["speed_b_dn"] = b;
    out["speed_sigma_dn"] = sigma;

    // OpenCV's band-pass filtering smooths: on a flat plane it beats the per-pixel limit.
    const cv::Mat flat = LinearProjectorMap(s9, kCamera);
    const auto stack_flat = RenderSyntheticStack(s9, flat, so);
    params->methodId = cv::structured_light::PSP;
    auto sp = cv::structured_light::SinusoidalPattern::create(params);
    cv::Mat wrapped, shadow;
    std::vector<cv::Mat> three_flat(stack_flat.begin(), stack_flat.begin() + 3);
    sp->computePhaseMap(three_flat, wrapped, shadow);
    out["opencv_psp_flat_rms_rad"] =
        EvaluatePeer(wrapped, cv::Mat(), shadow, s9, flat).wrapped_rms_rad;
    out["ours_flat_rms_rad"] = Evaluate(s9, Decode(s9, stack_flat), flat).wrapped_rms_rad;
  }

#ifdef FRINGE_BENCH_HAS_SIM
  // 4b. The virtual scanner: the demo part seen by the reference rig's left camera, projector
  // gamma 2.2 with pre-compensated heterodyne-4x3 patterns, read noise 1.5 DN, 3x3 supersampling.
  {
    const StereoRig rig = StereoRig::Reference();
    const sim::Scene scene = sim::MakeDemoPart();
    sim::RenderOptions ro;
    ro.sensor.seed = 51;
    const sim::Renderer renderer(scene, rig, ro);
    const Rigid3d pose = sim::SensorPoseLookingAt(rig, Eigen::Vector3d::Zero(),
                                                  Eigen::Vector3d(0.2, -0.3, 1).normalized());
    const PatternScheme s =
        MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
    const auto view = renderer.RenderView(pose, GeneratePatterns(s, ro.projector.gamma), 0);
    const auto& cam = view.left;
    DecodeResult r;
    const double ms = TimeMs(std::max(3, repeats / 3), [&] { Decode(s, cam.images, {}, &r); });
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
    out["sim_valid_fraction_of_lit"] =
        static_cast<double>(both) / std::max<int64_t>(truth_valid, 1);
    out["sim_abs_rms_px"] = std::sqrt(sum / std::max<int64_t>(both - wrong, 1));
    out["sim_wrong_order_fraction"] = static_cast<double>(wrong) / std::max<int64_t>(both, 1);
    out["sim_decode_ms"] = ms;
    out["sim_jump_fraction"] = JumpFraction(r.absolute_phase, r.mask, s.phase_sets[0].period_px);
  }
#endif

  // 5. Real capture (4-step + complementary Gray code).
  {
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
  }

  if (as_json) {
    std::cout << out.dump() << "\n";
    return 0;
  }
  auto num = [&](const char* k) {
    if (!out.contains(k)) return std::string("-");
    if (!out[k].is_number_float()) return out[k].dump();
    std::ostringstream os;
    os << std::setprecision(4) << out[k].get<double>();
    return os.str();
  };
  std::cout << "bench_phase (" << kCamera.width << "x" << kCamera.height << ", " << out["threads"]
            << " threads)\n\n"
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
  return 0;
}
