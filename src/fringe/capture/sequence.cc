#include "fringe/capture/sequence.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "fringe/util/error.h"

namespace fringe::capture {
namespace {

using util::StrCat;
using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

void SleepUntil(Clock::time_point t) { std::this_thread::sleep_until(t); }

Clock::time_point After(Clock::time_point t, double ms) {
  return t +
         std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(ms));
}

// Triggers every camera, then grabs one frame of each. Returns an empty string when every
// camera delivered a good frame, else why not (for the retry message). A lost camera throws.
std::string TriggerAndGrab(const std::vector<Camera*>& cameras, const SequenceOptions& options,
                           const std::vector<uint64_t>& last_ids, std::vector<Frame>* frames,
                           uint64_t* failed, Clock::time_point* triggered) {
  for (Camera* c : cameras) c->Drain();
  *triggered = Clock::now();
  for (Camera* c : cameras) c->Trigger();
  frames->assign(cameras.size(), Frame());
  std::string problem;
  for (size_t i = 0; i < cameras.size(); ++i) {
    GrabResult r = cameras[i]->Grab(options.grab_timeout_ms);
    if (r.status == GrabStatus::kLost) throw Error(r.message);
    if (r.status != GrabStatus::kOk) {
      ++*failed;
      if (problem.empty()) problem = r.message;
      continue;
    }
    if (last_ids[i] != 0 && r.frame.frame_id == last_ids[i]) {
      if (problem.empty()) {
        problem =
            StrCat("camera ", cameras[i]->Info().id, ": frame id ", r.frame.frame_id, " repeated");
      }
      continue;
    }
    (*frames)[i] = std::move(r.frame);
  }
  return problem;
}

}  // namespace

void SequenceOptions::Check() const {
  util::CheckOption(settle_ms >= 0 && settle_ms <= 10000, "SequenceOptions", "settle_ms", settle_ms,
                    "must be in [0, 10000] ms");
  util::CheckOption(grab_timeout_ms >= 1 && grab_timeout_ms <= 600000, "SequenceOptions",
                    "grab_timeout_ms", grab_timeout_ms, "must be in [1, 600000] ms");
  util::CheckOption(max_retries >= 0 && max_retries <= 100, "SequenceOptions", "max_retries",
                    max_retries, "must be in [0, 100]");
}

nlohmann::json ToJson(const SequenceOptions& o) {
  return {{"settle_ms", o.settle_ms},
          {"grab_timeout_ms", o.grab_timeout_ms},
          {"max_retries", o.max_retries}};
}

StackCapture CaptureStack(const std::vector<Camera*>& cameras, Projector& projector,
                          const std::vector<cv::Mat>& patterns, const SequenceOptions& options) {
  options.Check();
  if (cameras.empty()) throw Error("capture: no camera");
  StackCapture out;
  out.frames.assign(cameras.size(), {});
  out.records.assign(cameras.size(), {});
  std::vector<uint64_t> last_ids(cameras.size(), 0);
  const auto start = Clock::now();
  for (size_t k = 0; k < patterns.size(); ++k) {
    for (int attempt = 1;; ++attempt) {
      const auto shown = projector.Show(patterns[k]);
      SleepUntil(After(shown, options.settle_ms));
      std::vector<Frame> frames;
      Clock::time_point triggered;
      std::string problem;
      try {
        problem =
            TriggerAndGrab(cameras, options, last_ids, &frames, &out.frames_failed, &triggered);
      } catch (const Error& e) {
        // A camera that is gone: no retry can help; say which pattern it stopped at.
        throw Error(StrCat("capture: pattern ", k, " of ", patterns.size(), ": ", e.what()));
      }
      if (problem.empty()) {
        for (size_t i = 0; i < cameras.size(); ++i) {
          FrameRecord rec;
          rec.pattern = static_cast<int>(k);
          rec.attempts = attempt;
          rec.frame_id = frames[i].frame_id;
          rec.timestamp_ns = frames[i].timestamp_ns;
          rec.system_timestamp_ns = frames[i].system_timestamp_ns;
          rec.shown_s = Seconds(start, shown);
          rec.triggered_s = Seconds(start, triggered);
          last_ids[i] = frames[i].frame_id;
          out.records[i].push_back(rec);
          out.frames[i].push_back(std::move(frames[i]));
        }
        break;
      }
      if (attempt > options.max_retries) {
        throw Error(StrCat("capture: pattern ", k, " of ", patterns.size(),
                           ": no good frame after ", attempt, " tries: ", problem));
      }
      ++out.retries;
      out.retry_reasons.push_back(StrCat("pattern ", k, ": ", problem));
    }
  }
  out.seconds = Seconds(start, Clock::now());
  return out;
}

std::vector<Frame> CaptureLevel(const std::vector<Camera*>& cameras, Projector& projector,
                                int level, const SequenceOptions& options) {
  const cv::Mat pattern(projector.screen().height, projector.screen().width, CV_8UC1,
                        cv::Scalar(level));
  StackCapture s = CaptureStack(cameras, projector, {pattern}, options);
  std::vector<Frame> frames;
  for (auto& f : s.frames) frames.push_back(std::move(f[0]));
  return frames;
}

void LatencyOptions::Check() const {
  util::CheckOption(max_latency_ms > 0 && max_latency_ms <= 10000, "LatencyOptions",
                    "max_latency_ms", max_latency_ms, "must be in (0, 10000] ms");
  util::CheckOption(resolution_ms > 0 && resolution_ms <= max_latency_ms, "LatencyOptions",
                    "resolution_ms", resolution_ms, "must be in (0, max_latency_ms]");
  util::CheckOption(seen_fraction > 0.5 && seen_fraction < 1, "LatencyOptions", "seen_fraction",
                    seen_fraction, "must be in (0.5, 1)");
  util::CheckOption(min_contrast > 0 && min_contrast < 1, "LatencyOptions", "min_contrast",
                    min_contrast, "must be in (0, 1)");
}

nlohmann::json ToJson(const LatencyResult& r) {
  return {{"latency_ms", r.latency_ms},
          {"black_dn", r.black_dn},
          {"white_dn", r.white_dn},
          {"probes", r.probes},
          {"seconds", r.seconds}};
}

LatencyResult MeasureLatency(const std::vector<Camera*>& cameras, Projector& projector,
                             const LatencyOptions& options, const SequenceOptions& sequence) {
  options.Check();
  sequence.Check();
  LatencyResult r;
  const auto start = Clock::now();
  // References: each level held for the longest latency, so the cameras surely see it.
  SequenceOptions settled = sequence;
  settled.settle_ms = options.max_latency_ms;
  const auto black = CaptureLevel(cameras, projector, 0, settled);
  const auto white = CaptureLevel(cameras, projector, 255, settled);
  std::vector<double> threshold(cameras.size());
  for (size_t i = 0; i < cameras.size(); ++i) {
    const double full = std::ldexp(1.0, black[i].bit_depth) - 1;
    r.black_dn.push_back(cv::mean(black[i].image)[0]);
    r.white_dn.push_back(cv::mean(white[i].image)[0]);
    if (r.white_dn[i] - r.black_dn[i] < options.min_contrast * full) {
      throw Error(StrCat("measure latency: camera ", cameras[i]->Info().id,
                         " does not see the projector: mean level ", r.black_dn[i],
                         " DN under black and ", r.white_dn[i],
                         " DN under white (check aim, focus and exposure)"));
    }
    threshold[i] = r.black_dn[i] + options.seen_fraction * (r.white_dn[i] - r.black_dn[i]);
  }
  // Bisection on the delay d between "white presented" and the trigger: seen(d) is monotone
  // (later triggers see more of the new frame). Each probe starts from a settled black frame.
  auto seen = [&](double delay_ms) {
    projector.ShowLevel(0);
    std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(options.max_latency_ms));
    SequenceOptions probe = sequence;
    probe.settle_ms = delay_ms;
    const auto frames = CaptureLevel(cameras, projector, 255, probe);
    ++r.probes;
    for (size_t i = 0; i < frames.size(); ++i) {
      if (cv::mean(frames[i].image)[0] < threshold[i]) return false;
    }
    return true;
  };
  double lo = 0, hi = options.max_latency_ms;
  if (seen(lo)) {
    hi = lo;
  } else {
    while (hi - lo > options.resolution_ms) {
      const double mid = 0.5 * (lo + hi);
      (seen(mid) ? hi : lo) = mid;
    }
  }
  r.latency_ms = hi;
  r.seconds = Seconds(start, Clock::now());
  return r;
}

void AutoExposureOptions::Check() const {
  util::CheckOption(max_saturated_fraction >= 0 && max_saturated_fraction < 1,
                    "AutoExposureOptions", "max_saturated_fraction", max_saturated_fraction,
                    "must be in [0, 1)");
  util::CheckOption(min_lit_contrast > 0 && min_lit_contrast < 1, "AutoExposureOptions",
                    "min_lit_contrast", min_lit_contrast, "must be in (0, 1)");
  util::CheckOption(max_exposure_us > 0 && max_exposure_us <= 1e8, "AutoExposureOptions",
                    "max_exposure_us", max_exposure_us, "must be in (0, 1e8] us");
  util::CheckOption(resolution > 0 && resolution < 1, "AutoExposureOptions", "resolution",
                    resolution, "must be in (0, 1)");
}

nlohmann::json ToJson(const AutoExposureResult& r) {
  auto probe = [](const AutoExposureProbe& p) {
    return nlohmann::json{{"exposure_us", p.exposure_us},
                          {"saturated_fraction", p.saturated_fraction},
                          {"lit_fraction", p.lit_fraction}};
  };
  nlohmann::json probes = nlohmann::json::array();
  for (const auto& p : r.probes) probes.push_back(probe(p));
  return {{"exposure_us", r.exposure_us},
          {"range_us", {r.min_us, r.max_us}},
          {"chosen", probe(r.chosen)},
          {"probes", probes},
          {"seconds", r.seconds}};
}

LitPixels ClassifyLit(const Frame& black, const Frame& white, double min_lit_contrast) {
  if (black.image.size() != white.image.size()) {
    throw Error(StrCat("lit pixels: the black frame is ", black.image.cols, "x", black.image.rows,
                       " but the white frame ", white.image.cols, "x", white.image.rows));
  }
  const double full = std::ldexp(1.0, white.bit_depth) - 1;
  cv::Mat w, b;
  white.image.convertTo(w, CV_32F);
  black.image.convertTo(b, CV_32F);
  LitPixels r;
  r.lit = (w - b) >= min_lit_contrast * full;
  r.saturated = r.lit & (w >= full);
  const int lit_count = cv::countNonZero(r.lit);
  r.lit_fraction = static_cast<double>(lit_count) / static_cast<double>(w.total());
  r.saturated_fraction =
      lit_count > 0 ? static_cast<double>(cv::countNonZero(r.saturated)) / lit_count : 0.0;
  return r;
}

AutoExposureResult FindExposure(const std::vector<Camera*>& cameras, Projector& projector,
                                const CameraSettings& settings, const AutoExposureOptions& options,
                                const SequenceOptions& sequence) {
  options.Check();
  sequence.Check();
  if (cameras.empty()) throw Error("auto exposure: no camera");
  AutoExposureResult r;
  const auto start = Clock::now();
  r.min_us = 0;
  r.max_us = options.max_exposure_us;
  for (Camera* c : cameras) {
    double lo = 0, hi = 0;
    if (!c->ExposureRangeUs(&lo, &hi)) {
      throw Error(StrCat("auto exposure: camera ", c->Info().id,
                         " does not report its exposure range; give --exposure-us"));
    }
    r.min_us = std::max(r.min_us, lo);
    r.max_us = std::min(r.max_us, hi);
  }
  if (r.min_us > r.max_us) {
    throw Error(StrCat("auto exposure: the cameras have no exposure in common below ",
                       options.max_exposure_us, " us (shortest ", r.min_us, " us)"));
  }
  // The figures of every camera at one exposure: black and white frames, lit and saturated.
  auto probe = [&](double exposure_us) {
    CameraSettings s = settings;
    s.exposure_us = exposure_us;
    for (Camera* c : cameras) {
      c->Stop();
      c->Configure(s);
      c->Start();
    }
    const std::vector<Frame> black = CaptureLevel(cameras, projector, 0, sequence);
    const std::vector<Frame> white = CaptureLevel(cameras, projector, 255, sequence);
    AutoExposureProbe p;
    p.exposure_us = exposure_us;
    for (size_t i = 0; i < cameras.size(); ++i) {
      const LitPixels lit = ClassifyLit(black[i], white[i], options.min_lit_contrast);
      p.lit_fraction.push_back(lit.lit_fraction);
      p.saturated_fraction.push_back(lit.saturated_fraction);
    }
    r.probes.push_back(p);
    return p;
  };
  auto good = [&](const AutoExposureProbe& p) {
    for (double f : p.saturated_fraction) {
      if (f > options.max_saturated_fraction) return false;
    }
    return true;
  };
  AutoExposureProbe best = probe(r.max_us);
  double lo = r.min_us, hi = r.max_us;
  if (!good(best)) {
    AutoExposureProbe shortest = probe(r.min_us);
    if (!good(shortest)) {
      size_t worst = 0;
      for (size_t i = 1; i < cameras.size(); ++i) {
        if (shortest.saturated_fraction[i] > shortest.saturated_fraction[worst]) worst = i;
      }
      throw Error(StrCat("auto exposure: camera ", cameras[worst]->Info().id, " saturates ",
                         100 * shortest.saturated_fraction[worst],
                         " % of its lit pixels under white even at its shortest exposure ",
                         r.min_us, " us (allowed ", 100 * options.max_saturated_fraction,
                         " %): lower the gain or close the aperture"));
    }
    best = shortest;
    // Invariant: lo is good, hi is not. Bisection on log(exposure).
    while (hi > lo * (1 + options.resolution)) {
      const double mid = std::sqrt(lo * hi);
      const AutoExposureProbe p = probe(mid);
      if (good(p)) {
        lo = mid;
        best = p;
      } else {
        hi = mid;
      }
    }
    // Left configured at the chosen exposure.
    if (r.probes.back().exposure_us != best.exposure_us) probe(best.exposure_us);
  }
  r.exposure_us = best.exposure_us;
  r.chosen = best;
  r.seconds = Seconds(start, Clock::now());
  return r;
}

}  // namespace fringe::capture
