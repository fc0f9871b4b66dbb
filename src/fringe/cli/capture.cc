// fringe capture PROJECT: show the scheme's patterns on the projector, capture the cameras in
// sync and append the next view (or a calibration board pose) to the scan folder PROJECT.
// fringe devices: list the cameras and screens capture can use.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>

#include "fringe/capture/capture.h"
#include "fringe/capture/preview.h"
#include "fringe/cli/cli.h"
#include "fringe/cli/scheme_flags.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/util/error.h"

namespace fringe::cli {

void AddCaptureCommand(CLI::App& app) {
  struct Args {
    std::string project;
    std::string scheme;
    phase::SchemeParameters parameters;
    capture::CaptureOptions options;
    std::string trigger = "software";
    std::vector<int> roi;
    bool json = false;
    bool no_feedback = false;
    bool preview = false;
    std::string preview_screen;
    std::string preview_pattern = "white";
    int preview_frames = 0;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "capture",
      "Show the scheme's patterns on the projector, capture the cameras in sync and append the "
      "next view (or --board pose) to a scan folder (docs/capture.md)");
  sub->add_option("project", a->project,
                  "Scan folder to append to (created the first time: scan.json, scheme.json)")
      ->required();
  sub->add_option("--left", a->options.left,
                  "Left camera: Aravis device id, serial number or IP address (aravis:ID), or "
                  "opencv:N / /dev/videoN; `fringe devices` lists them")
      ->required();
  sub->add_option("--right", a->options.right,
                  "Right camera (as --left); without it the scan folder is a camera + projector "
                  "one");
  sub->add_option("--projector", a->options.projector,
                  "Projector screen: an X11 display and screen (:0.1), an output name (HDMI-1) "
                  "or a display index of $DISPLAY")
      ->required();
  sub->add_option("--scheme", a->scheme,
                  "Preset (with the scheme flags) or manifest JSON; default: the project's "
                  "scheme.json, or heterodyne-4x3 for a new project");
  AddSchemeFlags(sub, &a->parameters);
  auto& cam = a->options.camera;
  sub->add_option("--exposure-us", cam.exposure_us, "Exposure time, microseconds")
      ->capture_default_str()
      ->check(CLI::Range(1e-3, 1e8));
  sub->add_option(
         "--exposures", a->options.exposures_us,
         "HDR: capture the stack at each exposure (us, comma-separated) into e0/, e1/, ...")
      ->delimiter(',')
      ->check(CLI::Range(1e-3, 1e8));
  sub->add_flag("--auto-exposure", a->options.auto_exposure,
                "Before capturing, pick the longest exposure at which at most 0.1 % of the lit "
                "pixels saturate under a white frame (searched in the cameras' range)");
  sub->add_option("--max-exposure-us", a->options.auto_exposure_options.max_exposure_us,
                  "--auto-exposure: longest exposure searched, us")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1e8));
  sub->add_option("--gain", cam.gain, "Analog gain (the camera's unit, dB for GenICam)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  sub->add_option("--pixel-format", cam.pixel_format,
                  "Mono8, Mono10, Mono12, Mono14 or Mono16 (16-bit PNG, bit depth recorded)")
      ->capture_default_str();
  sub->add_option("--roi", a->roi, "Region of interest x,y,width,height (px)")
      ->delimiter(',')
      ->expected(4);
  sub->add_option("--trigger", a->trigger,
                  "software (TriggerSoftware), line1 (a hardware trigger from the projector on "
                  "input Line1; line0, line2, ... likewise) or free-run (webcams)")
      ->capture_default_str();
  auto& seq = a->options.sequence;
  sub->add_option("--settle-ms", a->options.settle_ms,
                  "Wait after a pattern is presented before triggering, ms (default: the "
                  "project's measured latency, else 100)")
      ->check(CLI::Range(0.0, 10000.0));
  sub->add_option("--timeout-ms", seq.grab_timeout_ms, "Longest wait for a frame, ms")
      ->capture_default_str()
      ->check(CLI::Range(1, 600000));
  sub->add_option("--retries", seq.max_retries,
                  "Re-shows of a pattern after an incomplete, missing or repeated frame")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));
  sub->add_flag("--measure-latency", a->options.measure_latency,
                "Only measure the delay after which the cameras see a new projector frame and "
                "store it in PROJECT/capture.json (used as the settle time from then on)");
  sub->add_option("--max-latency-ms", a->options.latency.max_latency_ms,
                  "--measure-latency: longest latency searched, ms")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 10000.0));
  sub->add_flag("--board", a->options.board,
                "Capture a calibration board pose instead of a view: two cameras, plain images "
                "under a white frame into calibration/{left,right}/KKK.png; one camera, the pose "
                "under white and fringes in both directions into calibration/KKK/ (projector "
                "calibration)");
  sub->add_option("--target", a->options.target_file,
                  "--board: the calibration target JSON, copied into the project the first time");
  sub->add_option("--rig", a->options.rig_file,
                  "Rig JSON for the 3D feedback (markers seen, registration to the previous "
                  "views and overlap); default PROJECT/rig.json when it exists")
      ->check(CLI::ExistingFile);
  sub->add_flag("--no-feedback", a->no_feedback, "Do not decode the new view for the feedback");
  sub->add_flag("--preview", a->preview,
                "Set up the sensor instead of capturing: both cameras live in a window (saturated "
                "pixels red, a focus measure, the fraction each camera sees lit by the projector); "
                "nothing is written to PROJECT");
  sub->add_option("--preview-screen", a->preview_screen,
                  "--preview: the operator's X11 display for the window (default $DISPLAY)");
  sub->add_option("--preview-pattern", a->preview_pattern,
                  "--preview: what the projector shows: white, focus (a fine checkerboard) or "
                  "crosshair; keys w, f, c switch in the window")
      ->capture_default_str()
      ->check(CLI::IsMember({"white", "focus", "crosshair"}));
  sub->add_option("--preview-frames", a->preview_frames,
                  "--preview: refreshes before exiting (0: until the window is closed or q)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000000));
  sub->add_flag("--json", a->json, "Print the capture summary (--preview: the figures) as JSON");
  sub->callback([a] {
    capture::CaptureOptions o = a->options;
    o.camera.trigger = capture::ParseTriggerSource(a->trigger);
    if (o.camera.trigger == capture::TriggerSource::kLine1) {
      o.camera.trigger_line = "Line" + a->trigger.substr(4);
    }
    if (!a->roi.empty()) {
      o.camera.roi_x = a->roi[0];
      o.camera.roi_y = a->roi[1];
      o.camera.roi_width = a->roi[2];
      o.camera.roi_height = a->roi[3];
    }
    o.feedback = !a->no_feedback;
    const scan::ScanLayout layout{a->project};
    phase::PatternScheme scheme;
    if (a->scheme.empty() && !a->parameters.AnySet() &&
        std::filesystem::is_regular_file(layout.Scheme())) {
      scheme = phase::ReadScheme(layout.Scheme());
    } else {
      scheme = phase::SchemeFromArgument(a->scheme.empty() ? "heterodyne-4x3" : a->scheme,
                                         a->parameters);
    }
    if (a->preview) {
      // Setting up only: the settings that decide what a capture writes have no meaning here.
      if (o.board || o.measure_latency || o.auto_exposure || !o.exposures_us.empty()) {
        throw Error(
            "--preview does not capture: drop --board, --measure-latency, --auto-exposure and "
            "--exposures");
      }
      capture::PreviewOptions p;
      p.left = o.left;
      p.right = o.right;
      p.projector = o.projector;
      p.projector_width = scheme.projector_width;
      p.projector_height = scheme.projector_height;
      p.preview_screen = a->preview_screen;
      p.camera = o.camera;
      p.sequence = o.sequence;
      // The project is only read (its measured latency), never created.
      if (o.settle_ms >= 0) {
        p.sequence.settle_ms = o.settle_ms;
      } else if (auto ms = capture::ReadProjectLatency(a->project)) {
        p.sequence.settle_ms = *ms;
      }
      p.pattern = capture::ParsePreviewPattern(a->preview_pattern);
      p.frames = a->preview_frames;
      const capture::PreviewResult r = capture::RunPreview(p);
      if (a->json) {
        std::cout << capture::ToJson(r).dump(2) << "\n";
      } else {
        std::cout << "preview: " << r.refreshes << " refreshes in " << r.seconds << " s, "
                  << r.pattern << "\n";
        for (const auto& f : r.cameras) {
          std::cout << "  " << f.camera << " " << f.id << ": saturated " << f.saturated_pct
                    << " % (" << f.saturated_lit_pct << " % of the lit pixels under white), focus "
                    << f.focus << ", lit " << 100 * f.lit_fraction << " %\n";
        }
      }
      return;
    }
    const capture::CaptureSummary s = capture::CaptureIntoProject(a->project, scheme, o);
    if (a->json) {
      std::cout << capture::ToJson(s).dump(2) << "\n";
    } else {
      std::cout << s.BriefReport() << "\n";
    }
  });
}

void AddDevicesCommand(CLI::App& app) {
  struct Args {
    std::string display;
    bool json = false;
    bool no_opencv = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "devices",
      "List the cameras (Aravis: GigE Vision / USB3 Vision; OpenCV: V4L2) and the "
      "screens capture can use");
  sub->add_option("--display", a->display,
                  "X11 display whose screens are listed (default $DISPLAY)");
  sub->add_flag("--no-opencv", a->no_opencv, "Do not probe /dev/video* (OpenCV VideoCapture)");
  sub->add_flag("--json", a->json, "Print the list as JSON");
  sub->callback([a] {
    const capture::DeviceList d = capture::ListDevices(a->display, !a->no_opencv);
    if (a->json) {
      std::cout << capture::ToJson(d).dump(2) << "\n";
      return;
    }
    std::cout << "cameras: " << d.cameras.size() << "\n";
    for (const auto& c : d.cameras) {
      std::cout << "  " << c.backend << "  " << c.id << "  model " << c.model << "  serial "
                << (c.serial.empty() ? "-" : c.serial) << "  " << c.interface << "  "
                << (c.pixel_format.empty() ? "?" : c.pixel_format) << " " << c.width << "x"
                << c.height << "\n";
    }
    std::cout << "screens: " << d.screens.size() << "\n";
    for (const auto& s : d.screens) {
      std::cout << "  " << s.display << "  " << s.index << " '" << s.name << "'  " << s.width << "x"
                << s.height << " at " << s.x << "," << s.y;
      if (s.refresh_hz > 0) std::cout << "  " << s.refresh_hz << " Hz";
      std::cout << "\n";
    }
    if (!d.screens_error.empty()) std::cout << "  (" << d.screens_error << ")\n";
  });
}

FRINGE_REGISTER_COMMAND(25, AddCaptureCommand);
FRINGE_REGISTER_COMMAND(24, AddDevicesCommand);

}  // namespace fringe::cli
