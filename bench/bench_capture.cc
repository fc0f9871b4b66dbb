// Capture speed and latency on the loopback setup of the capture tests: two of Aravis' fake
// GigE Vision cameras on 127.0.0.2 / 127.0.0.3 (a private network namespace, entered here; needs
// root) and Xvfb as the projector screen, the cameras seeing the projector window through the
// X server.
//   build/bench/bench_capture [--json] [--views 5] [--exposure-us 1000] [--latency-ms 30]
//
// Figures:
//   latency_measured_ms   what --measure-latency finds when the cameras see the screen
//                         latency_injected_ms late (the fake cameras sample the screen every
//                         0.25 ms and show the level it had that long before);
//   view_s                median wall time of one view (2 cameras x the scheme's 12 patterns)
//                         captured with the measured latency as the settle time;
//   view_limit_s          1.25 x patterns x (1 / refresh + exposure + measured latency), the
//                         issue's bound (refresh: the screen's, 60 Hz when it reports none);
//   frames_per_s          frames received per second (both cameras) during the views;
//   dropped_frames        incomplete or missing frames (retried) at the default packet loss (0).
#include <CLI/CLI.hpp>

#include <unistd.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "bench_timing.h"
#include "fringe/capture/capture.h"
#include "fringe/phase/scheme_presets.h"
#include "fringe/testing/capture_rig.h"
#include "fringe/util/files.h"

namespace fs = std::filesystem;
using namespace fringe;

int main(int argc, char** argv) {
  bool json = false;
  int views = 5;
  double exposure_us = 1000, latency_ms = 30;
  CLI::App app("Capture speed and latency on fake GigE Vision cameras + Xvfb");
  app.add_flag("--json", json, "Print one JSON object");
  app.add_option("--views", views, "Views captured for the timing")->check(CLI::Range(1, 100));
  app.add_option("--exposure-us", exposure_us, "Exposure time")->check(CLI::Range(1.0, 1e6));
  app.add_option("--latency-ms", latency_ms, "Injected latency")->check(CLI::Range(1.0, 500.0));
  CLI11_PARSE(app, argc, argv);
  try {
    capture::test::EnterPrivateNetworkNamespace();
    const int pw = 640, ph = 400, cw = 640, ch = 512;
    capture::test::Xvfb xvfb(pw, ph);
    auto resample = [](bool mirror) {
      return [mirror](const cv::Mat& screen, double, double, int w, int h, int depth) {
        return capture::test::ResampleProjector(screen, w, h, depth, mirror);
      };
    };
    phase::SchemeParameters p;
    p.projector_width = pw;
    p.projector_height = ph;
    const phase::PatternScheme scheme = phase::SchemeFromArgument("heterodyne-4x3", p);
    const fs::path project =
        fs::temp_directory_path() / ("bench_capture_" + std::to_string(getpid()));
    fs::remove_all(project);
    capture::CaptureOptions o;
    o.left = "127.0.0.2";
    o.right = "127.0.0.3";
    o.projector = xvfb.display();
    o.camera.exposure_us = exposure_us;
    o.feedback = false;

    // 1. Latency: cameras that see the screen latency_ms late.
    double measured_ms = 0, refresh_hz = 0;
    {
      capture::test::FakeCamera left("127.0.0.2", "BENCH-L", xvfb.display(), resample(false));
      capture::test::FakeCamera right("127.0.0.3", "BENCH-R", xvfb.display(), resample(true));
      left.SetSize(cw, ch);
      right.SetSize(cw, ch);
      left.SetInjectedLatency(latency_ms);
      right.SetInjectedLatency(latency_ms);
      capture::CaptureOptions m = o;
      m.measure_latency = true;
      m.latency.max_latency_ms = 4 * latency_ms;
      measured_ms = capture::CaptureIntoProject(project, scheme, m).latency_ms;
      refresh_hz = capture::ListScreens(xvfb.display()).at(0).refresh_hz;
    }
    // 2. Views at the measured settle time (the project's capture.json).
    capture::test::FakeCamera left("127.0.0.2", "BENCH-L2", xvfb.display(), resample(false));
    capture::test::FakeCamera right("127.0.0.3", "BENCH-R2", xvfb.display(), resample(true));
    left.SetSize(cw, ch);
    right.SetSize(cw, ch);
    std::vector<double> view_s;
    int frames = 0, retries = 0;
    uint64_t failed = 0;
    double capture_total_s = 0;
    for (int v = 0; v < views; ++v) {
      const capture::CaptureSummary s = capture::CaptureIntoProject(project, scheme, o);
      view_s.push_back(s.capture_s);
      capture_total_s += s.capture_s;
      frames += s.patterns * static_cast<int>(s.cameras.size());
      retries += s.retries;
      failed += s.frames_failed;
    }
    fs::remove_all(project);
    const double refresh = refresh_hz > 0 ? refresh_hz : 60.0;
    const int n = scheme.NumImages();
    const double limit_s = 1.25 * n * (1.0 / refresh + exposure_us * 1e-6 + measured_ms * 1e-3);
    const double median_view_s = bench::Median(view_s);
    nlohmann::json j = {{"projector", {pw, ph}},
                        {"camera", {cw, ch}},
                        {"cameras", 2},
                        {"patterns", n},
                        {"views", views},
                        {"exposure_us", exposure_us},
                        {"refresh_hz", refresh_hz},
                        {"latency_injected_ms", latency_ms},
                        {"latency_measured_ms", measured_ms},
                        {"latency_error_ms", measured_ms - latency_ms},
                        {"view_s", median_view_s},
                        {"view_limit_s", limit_s},
                        {"view_within_limit", median_view_s <= limit_s},
                        {"frames_per_s", frames / capture_total_s},
                        {"dropped_frames", failed},
                        {"retries", retries}};
    if (json) {
      std::cout << j.dump(2) << "\n";
    } else {
      std::cout << "latency: injected " << latency_ms << " ms, measured " << measured_ms
                << " ms\nview: " << median_view_s << " s (limit " << limit_s << " s), "
                << frames / capture_total_s << " frames/s, dropped " << failed << "\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "bench_capture: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
