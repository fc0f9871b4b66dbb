#include "fringe/capture/capture.h"

#include <unistd.h>
#include <chrono>
#include <cmath>

#include "fringe/capture/projector.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/json.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::capture {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using util::StrCat;
using Clock = std::chrono::steady_clock;

constexpr const char* kCaptureSettings = "capture.json";  // PROJECT/ and views/NNN/
constexpr const char* kTemporary = ".capture-tmp";        // PROJECT/.capture-tmp/

double Seconds(Clock::time_point a) {
  return std::chrono::duration<double>(Clock::now() - a).count();
}

std::string Iso8601Now() {
  const std::time_t t = std::time(nullptr);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return text;
}

// The devices of one capture, opened and configured; closed (acquisition stopped, window
// destroyed) when this goes out of scope, also on an error.
struct Devices {
  std::vector<std::unique_ptr<Camera>> owned;
  std::vector<Camera*> cameras;
  std::vector<CameraInfo> infos;
  std::unique_ptr<Projector> projector;
  int bit_depth = 8;
  ~Devices() {
    for (auto& c : owned) {
      try {
        c->Stop();
      } catch (...) {
        // Closing after an error: the first error is the one reported.
      }
    }
  }
};

void OpenDevices(const phase::PatternScheme& scheme, const CaptureOptions& o,
                 const CameraSettings& settings, Devices& d) {
  // The projector first: a wrong screen is found before the cameras are touched.
  d.projector = Projector::Open(o.projector, scheme.projector_width, scheme.projector_height);
  for (const std::string& spec : {o.left, o.right}) {
    if (spec.empty()) continue;
    d.owned.push_back(OpenCamera(spec));
    d.owned.back()->Configure(settings);
    d.cameras.push_back(d.owned.back().get());
    d.infos.push_back(d.owned.back()->Info());
  }
  if (d.infos.size() == 2 &&
      (d.infos[0].width != d.infos[1].width || d.infos[0].height != d.infos[1].height)) {
    throw Error(StrCat("cameras: the left camera ", d.infos[0].id, " gives ", d.infos[0].width, "x",
                       d.infos[0].height, " images but the right camera ", d.infos[1].id, " gives ",
                       d.infos[1].width, "x", d.infos[1].height,
                       " (a scan folder has one image size; set --roi)"));
  }
  d.bit_depth = 8;
  if (!d.infos.empty()) {
    const std::string& format = d.infos[0].pixel_format;
    if (format.rfind("Mono", 0) == 0 && format.size() <= 6)
      d.bit_depth = std::stoi(format.substr(4));
  }
  for (Camera* c : d.cameras) c->Start();
}

// Packet statistics of every camera. Reconfiguring for another exposure restarts the stream,
// so they count the last exposure's stream only.
void AddStreamStatistics(const Devices& d, CaptureSummary* s) {
  for (Camera* c : d.cameras) {
    const StreamStatistics st = c->Statistics();
    s->resent_packets += st.resent_packets;
    s->missing_packets += st.missing_packets;
  }
}

json FrameRecordsToJson(const std::vector<FrameRecord>& records,
                        const std::vector<std::string>& names) {
  json out = json::array();
  for (const FrameRecord& r : records) {
    out.push_back({{"image", names[r.pattern]},
                   {"frame_id", r.frame_id},
                   {"timestamp_ns", r.timestamp_ns},
                   {"system_timestamp_ns", r.system_timestamp_ns},
                   {"attempts", r.attempts},
                   {"shown_s", r.shown_s},
                   {"triggered_s", r.triggered_s}});
  }
  return out;
}

json SettingsToJson(const CameraSettings& s) {
  return {{"exposure_us", s.exposure_us},
          {"gain", s.gain},
          {"pixel_format", s.pixel_format},
          {"roi", {s.roi_x, s.roi_y, s.roi_width, s.roi_height}},
          {"trigger", TriggerSourceName(s.trigger)},
          {"trigger_line", s.trigger == TriggerSource::kLine1 ? json(s.trigger_line) : json()}};
}

// The folder the capture writes into: an existing scan folder (checked), or a new one.
struct Project {
  fs::path root;
  bool exists = false;
  scan::ScanManifest manifest;
};

Project OpenProject(const fs::path& root, const phase::PatternScheme& scheme, int cameras) {
  Project p;
  p.root = root;
  std::error_code ec;
  if (scan::ScanFolder::IsScanFolder(root)) {
    const scan::ScanFolder folder = scan::ScanFolder::Open(root);
    p.exists = true;
    p.manifest = folder.manifest();
    if (p.manifest.cameras != cameras) {
      throw Error(StrCat(folder.layout().Manifest().string(), ": the project has ",
                         p.manifest.cameras, " camera(s) but ", cameras, " were given"));
    }
    if (!p.manifest.scheme.empty()) {
      const phase::PatternScheme own = folder.ReadScheme();
      if (phase::SchemeToJson(own) != phase::SchemeToJson(scheme)) {
        throw Error(StrCat(folder.layout().Scheme().string(), ": the project's pattern scheme '",
                           own.name, "' (", own.projector_width, "x", own.projector_height, ", ",
                           own.NumImages(), " images) differs from the scheme given ('",
                           scheme.name, "', ", scheme.projector_width, "x", scheme.projector_height,
                           ", ", scheme.NumImages(),
                           " images); capture into a new project or leave out --scheme"));
      }
    }
    if (!p.manifest.scheme_horizontal.empty()) {
      throw Error(StrCat(folder.layout().Manifest().string(),
                         ": views with both fringe directions are not captured by fringe capture"));
    }
    return p;
  }
  if (fs::exists(root, ec) && !(fs::is_directory(root, ec) && fs::is_empty(root, ec))) {
    throw Error(StrCat(root.string(),
                       ": exists and is not a scan folder (no scan.json); give a "
                       "new folder or an existing project"));
  }
  return p;
}

// Writes `write(dir)` into the project: for an existing project into PROJECT/.capture-tmp/<name>
// which is then renamed to `final_dir`; for a new project the whole project is built in a
// temporary folder and renamed into place (util::WriteFolderAtomically), so a failure leaves no
// folder at all.
void CommitView(const Project& p, const fs::path& relative, const scan::ScanManifest& manifest,
                const phase::PatternScheme& scheme,
                const std::function<void(const fs::path& dir)>& write_view,
                const std::function<void(const fs::path& root)>& write_extra) {
  if (!p.exists) {
    util::WriteFolderAtomically(p.root, [&](const fs::path& tmp) {
      phase::WriteScheme(scan::ScanLayout{tmp}.Scheme(), scheme);
      if (!relative.empty()) {
        fs::create_directories(tmp / relative);
        write_view(tmp / relative);
      }
      if (write_extra) write_extra(tmp);
      scan::WriteManifest(scan::ScanLayout{tmp}.Manifest(), manifest);
    });
    return;
  }
  const fs::path staging = p.root / kTemporary / relative.filename();
  std::error_code ec;
  fs::remove_all(p.root / kTemporary, ec);  // left by a killed capture
  try {
    if (!relative.empty()) {
      fs::create_directories(staging);
      write_view(staging);
    }
    if (write_extra) write_extra(p.root);
    if (!relative.empty()) {
      fs::create_directories((p.root / relative).parent_path());
      if (fs::exists(p.root / relative)) {
        throw Error(StrCat((p.root / relative).string(),
                           ": already exists although scan.json does not count it; remove it or "
                           "fix scan.json"));
      }
      fs::rename(staging, p.root / relative);
    }
  } catch (const fs::filesystem_error& e) {
    fs::remove_all(p.root / kTemporary, ec);
    throw Error(StrCat((p.root / relative).string(), ": cannot write: ", e.code().message()));
  } catch (...) {
    fs::remove_all(p.root / kTemporary, ec);
    throw;
  }
  fs::remove_all(p.root / kTemporary, ec);
  // The view is in place; the manifest now counts it (temporary + rename).
  scan::WriteManifest(scan::ScanLayout{p.root}.Manifest(), manifest);
}

void WriteProjectLatency(const fs::path& root, const LatencyResult& r,
                         const std::vector<CameraInfo>& cameras, const std::string& projector) {
  json j = {{"format", "fringe-capture-settings"},
            {"version", 1},
            {"latency_ms", r.latency_ms},
            {"measured_at", Iso8601Now()},
            {"latency", ToJson(r)},
            {"projector", projector},
            {"cameras", json::array()}};
  for (const auto& c : cameras) j["cameras"].push_back(ToJson(c));
  io::WriteJson(root / kCaptureSettings, j);
}

}  // namespace

void CaptureOptions::Check() const {
  camera.Check();
  sequence.Check();
  latency.Check();
  util::CheckOption(!left.empty(), "CaptureOptions", "left", left, "a left camera is required");
  util::CheckOption(!projector.empty(), "CaptureOptions", "projector", projector,
                    "a projector screen is required");
  util::CheckOption(settle_ms <= 10000, "CaptureOptions", "settle_ms", settle_ms,
                    "must be <= 10000 ms (< 0: the measured latency)");
  util::CheckOption(exposures_us.size() <= 16, "CaptureOptions", "exposures_us",
                    exposures_us.size(), "at most 16 exposures");
  for (double e : exposures_us) {
    util::CheckOption(e > 0 && e <= 1e8, "CaptureOptions", "exposures_us", e,
                      "every exposure must be in (0, 1e8] us");
  }
  auto_exposure_options.Check();
  util::CheckOption(!auto_exposure || exposures_us.size() <= 1, "CaptureOptions", "auto_exposure",
                    exposures_us.size(), "auto exposure picks one exposure, not several");
  if (horizontal_scheme) {
    util::CheckOption(horizontal_scheme->direction == phase::FringeDirection::kHorizontal,
                      "CaptureOptions", "horizontal_scheme", horizontal_scheme->name,
                      "must have horizontal fringes");
  }
}

std::optional<double> ReadProjectLatency(const fs::path& project) {
  const fs::path file = project / kCaptureSettings;
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) return std::nullopt;
  const json j = io::ReadJson(file);
  return io::WithJsonContext(file.string(), [&]() -> std::optional<double> {
    const double ms = j.at("latency_ms").get<double>();
    if (!(ms >= 0 && ms <= 10000)) throw Error(StrCat("'latency_ms' = ", ms, " not in [0, 10000]"));
    return ms;
  });
}

CameraFeedback AssessStack(const phase::PatternScheme& scheme, const std::vector<cv::Mat>& images,
                           int bit_depth, const phase::DecodeOptions& decode) {
  CameraFeedback f;
  phase::DecodeOptions o = decode;
  const double full = std::ldexp(1.0, bit_depth) - 1;
  if (o.full_scale_dn <= 0) o.full_scale_dn = full;
  const phase::DecodeResult r = phase::Decode(scheme, images, o);
  const double pixels = static_cast<double>(images[0].total());
  // Saturated: any phase-shift image at full scale (the decoder's rejection counts only the
  // first failing reason; this is what the operator adjusts the exposure for).
  cv::Mat saturated = cv::Mat::zeros(images[0].size(), CV_8U);
  for (size_t s = 0; s < scheme.phase_sets.size(); ++s) {
    const int first = scheme.PhaseImageIndex(static_cast<int>(s));
    for (int k = 0; k < scheme.phase_sets[s].steps; ++k) {
      saturated |= images[first + k] >= (o.saturation_dn > 0 ? o.saturation_dn : o.full_scale_dn);
    }
  }
  f.saturated_pct = 100.0 * cv::countNonZero(saturated) / pixels;
  const cv::Mat modulated = r.modulation >= r.summary.min_modulation_dn;
  f.modulated_pct = 100.0 * cv::countNonZero(modulated) / pixels;
  f.decodable_pct = 100.0 * r.summary.ValidFraction();
  f.decode_status =
      r.summary.status == phase::DecodeStatus::kSuccess ? "success" : "no valid pixels";
  return f;
}

std::string CaptureSummary::BriefReport() const {
  std::string s =
      StrCat(kind, " ", name, ": ", patterns, " patterns x ", cameras.size(), " camera(s) x ",
             exposures, " exposure(s) in ", capture_s, " s (settle ", settle_ms, " ms, ", retries,
             " retries, ", frames_failed, " failed frames)");
  if (latency_ms >= 0) s += StrCat("; latency ", latency_ms, " ms");
  if (auto_exposure) {
    double worst = 0;
    for (double f : auto_exposure->chosen.saturated_fraction) worst = std::max(worst, f);
    s += StrCat("\n  auto exposure: ", auto_exposure->exposure_us, " us (", 100 * worst,
                " % of the lit pixels saturated under white; ", auto_exposure->probes.size(),
                " probes in [", auto_exposure->min_us, ", ", auto_exposure->max_us, "] us)");
  }
  for (const auto& f : feedback) {
    s += StrCat("\n  ", f.camera, ": saturated ", f.saturated_pct, " %, modulated ",
                f.modulated_pct, " %, decodable ", f.decodable_pct, " %");
  }
  if (view) {
    if (!view->reconstructed) {
      s += StrCat("\n  3D: not reconstructed: ", view->message);
    } else {
      s += StrCat("\n  3D: ", view->points, " points, ", view->markers, " markers seen (rings ",
                  view->rings_left, " left, ", view->rings_right, " right)");
      if (!view->registration_run) {
        s += "; the first view (registration from the second on)";
      } else if (view->registered) {
        s += StrCat("; registers to the ", view->previous_views, " previous view(s) by ",
                    view->registration_path, " (", view->matched_markers,
                    " shared markers), overlap ", 100 * view->overlap_fraction, " %");
      } else {
        s += StrCat("; does NOT register to the ", view->previous_views,
                    " previous view(s): ", view->registration_message,
                    " (point the sensor to overlap them more)");
      }
    }
  } else if (!view_message.empty()) {
    s += StrCat("\n  ", view_message);
  }
  return s;
}

json ToJson(const CaptureSummary& s) {
  json j = {{"kind", s.kind},
            {"name", s.name},
            {"path", s.path.string()},
            {"latency_ms", s.latency_ms >= 0 ? json(s.latency_ms) : json()},
            {"settle_ms", s.settle_ms},
            {"exposure_us", s.exposure_us},
            {"auto_exposure", s.auto_exposure ? ToJson(*s.auto_exposure) : json()},
            {"patterns", s.patterns},
            {"exposures", s.exposures},
            {"retries", s.retries},
            {"frames_failed", s.frames_failed},
            {"resent_packets", s.resent_packets},
            {"missing_packets", s.missing_packets},
            {"capture_s", s.capture_s},
            {"total_s", s.total_s},
            {"cameras", json::array()},
            {"feedback", json::array()}};
  for (const auto& c : s.cameras) j["cameras"].push_back(ToJson(c));
  for (const auto& f : s.feedback) {
    j["feedback"].push_back({{"camera", f.camera},
                             {"saturated_pct", f.saturated_pct},
                             {"modulated_pct", f.modulated_pct},
                             {"decodable_pct", f.decodable_pct},
                             {"decode_status", f.decode_status}});
  }
  j["view_feedback"] = s.view ? ToJson(*s.view) : json();
  if (!s.view_message.empty()) j["view_feedback_message"] = s.view_message;
  return j;
}

CaptureSummary CaptureIntoProject(const fs::path& root, const phase::PatternScheme& scheme,
                                  const CaptureOptions& options) {
  const auto start = Clock::now();
  options.Check();
  scheme.Check();
  const int camera_count = options.right.empty() ? 1 : 2;
  Project project = OpenProject(root, scheme, camera_count);
  if (options.board && project.manifest.calibration_images > 0 && !options.target_file.empty()) {
    // Only checked: the project's target stays.
  }
  if (options.board && project.manifest.calibration_images == 0 && options.target_file.empty()) {
    throw Error("--board: the first board pose needs --target FILE (the calibration board)");
  }
  if (!options.target_file.empty()) io::ReadTarget(options.target_file);  // validates it
  // The feedback's rig is read before anything is shown: a bad file fails the capture now, not
  // after the view was taken.
  fs::path rig_file = options.rig_file;
  if (rig_file.empty() && project.exists && fs::is_regular_file(root / "rig.json"))
    rig_file = root / "rig.json";
  if (!rig_file.empty() && options.feedback && !options.board) io::ReadRig(rig_file);

  CameraSettings settings = options.camera;
  if (!options.exposures_us.empty()) settings.exposure_us = options.exposures_us[0];
  Devices devices;
  OpenDevices(scheme, options, settings, devices);

  CaptureSummary summary;
  summary.cameras = devices.infos;
  const int width = devices.infos[0].width, height = devices.infos[0].height;
  if (project.exists &&
      (project.manifest.image_width != width || project.manifest.image_height != height ||
       project.manifest.bit_depth != devices.bit_depth)) {
    throw Error(StrCat(scan::ScanLayout{root}.Manifest().string(), ": the project's images are ",
                       project.manifest.image_width, "x", project.manifest.image_height, " ",
                       project.manifest.bit_depth, "-bit but camera ", devices.infos[0].id,
                       " gives ", width, "x", height, " ", devices.bit_depth, "-bit"));
  }
  if (!project.exists) {
    project.manifest.generator = "fringe capture";
    project.manifest.image_width = width;
    project.manifest.image_height = height;
    project.manifest.bit_depth = devices.bit_depth;
    project.manifest.cameras = camera_count;
    project.manifest.scheme = "scheme.json";
  }

  // Settle time: measured now, measured before, or given.
  SequenceOptions sequence = options.sequence;
  if (options.settle_ms >= 0) {
    sequence.settle_ms = options.settle_ms;
  } else if (project.exists) {
    if (auto ms = ReadProjectLatency(root)) sequence.settle_ms = *ms;
  }
  if (options.auto_exposure) {
    summary.auto_exposure = FindExposure(devices.cameras, *devices.projector, settings,
                                         options.auto_exposure_options, sequence);
    settings.exposure_us = summary.auto_exposure->exposure_us;
  }
  summary.exposure_us = settings.exposure_us;
  if (options.measure_latency) {
    const LatencyResult latency =
        MeasureLatency(devices.cameras, *devices.projector, options.latency, sequence);
    summary.latency_ms = latency.latency_ms;
    summary.kind = "latency";
    summary.settle_ms = latency.latency_ms;
    CommitView(project, {}, project.manifest, scheme, nullptr, [&](const fs::path& dir) {
      WriteProjectLatency(dir, latency, devices.infos, options.projector);
    });
    summary.path = root / kCaptureSettings;
    summary.total_s = Seconds(start);
    return summary;
  }
  summary.settle_ms = sequence.settle_ms;

  const auto names = scheme.ImageNames();
  const char* camera_names[2] = {"left", "right"};
  json settings_json = {{"format", "fringe-capture-view"},
                        {"version", 1},
                        {"captured_at", Iso8601Now()},
                        {"projector",
                         {{"screen", options.projector},
                          {"renderer", devices.projector->renderer()},
                          {"screen_info", ToJson(devices.projector->screen())}}},
                        {"scheme", scheme.name},
                        {"bit_depth", devices.bit_depth},
                        {"camera_settings", SettingsToJson(settings)},
                        {"sequence", ToJson(sequence)}};
  if (summary.auto_exposure) settings_json["auto_exposure"] = ToJson(*summary.auto_exposure);

  if (options.board && camera_count == 1) {
    // Camera + projector calibration: the board pose under a white frame, then under the
    // scheme's fringes in both directions, in one sequence (the board must not move), written
    // as the pose folder calibration/KKK/{board.png, vertical/, horizontal/} that
    // `fringe calibrate` and `fringe scan` read (calib/projector_folder.h).
    if (scheme.direction != phase::FringeDirection::kVertical) {
      throw Error(StrCat("--board: the scheme '", scheme.name,
                         "' has horizontal fringes; give the vertical one (the horizontal one is "
                         "derived from it)"));
    }
    phase::PatternScheme horizontal = scheme;
    if (options.horizontal_scheme) {
      horizontal = *options.horizontal_scheme;
    } else {
      // The same periods and steps along the rows (as the simulator's one-camera scans).
      horizontal.direction = phase::FringeDirection::kHorizontal;
      horizontal.name = scheme.name + "-horizontal";
    }
    horizontal.Check();
    if (horizontal.projector_width != scheme.projector_width ||
        horizontal.projector_height != scheme.projector_height) {
      throw Error(StrCat("--board: the horizontal scheme '", horizontal.name, "' is for a ",
                         horizontal.projector_width, "x", horizontal.projector_height,
                         " projector, the vertical one for ", scheme.projector_width, "x",
                         scheme.projector_height));
    }
    std::vector<cv::Mat> shown = {
        cv::Mat(scheme.projector_height, scheme.projector_width, CV_8UC1, cv::Scalar(255))};
    const std::vector<cv::Mat> vp = phase::GeneratePatterns(scheme, scheme.gamma_precompensation);
    const std::vector<cv::Mat> hp =
        phase::GeneratePatterns(horizontal, horizontal.gamma_precompensation);
    shown.insert(shown.end(), vp.begin(), vp.end());
    shown.insert(shown.end(), hp.begin(), hp.end());
    const auto t0 = Clock::now();
    StackCapture shot = CaptureStack(devices.cameras, *devices.projector, shown, sequence);
    summary.capture_s = Seconds(t0);
    AddStreamStatistics(devices, &summary);
    summary.kind = "board";
    summary.patterns = static_cast<int>(shown.size());
    summary.retries = shot.retries;
    summary.frames_failed = shot.frames_failed;
    const int index = project.manifest.calibration_images;
    summary.name = scan::IndexName(index);
    scan::ScanManifest manifest = project.manifest;
    manifest.calibration_images = index + 1;
    manifest.calibration_target = "calibration/target.json";
    const fs::path relative = fs::path("calibration") / summary.name;
    summary.path = root / relative;
    json pose_json = settings_json;
    pose_json["format"] = "fringe-capture-board-pose";
    pose_json["horizontal_scheme"] = horizontal.name;
    pose_json["cameras"] = {ToJson(devices.infos[0])};
    std::vector<std::string> names = {"board.png"};
    for (const auto& n : scheme.ImageNames()) names.push_back("vertical/" + n);
    for (const auto& n : horizontal.ImageNames()) names.push_back("horizontal/" + n);
    pose_json["cameras"][0]["frames"] = FrameRecordsToJson(shot.records[0], names);
    CommitView(
        project, relative, manifest, scheme,
        [&](const fs::path& dir) {
          fs::create_directories(dir / "vertical");
          fs::create_directories(dir / "horizontal");
          for (size_t k = 0; k < names.size(); ++k) {
            io::WriteImage(dir / names[k], shot.frames[0][k].image);
          }
          phase::WriteScheme(dir / "vertical" / "manifest.json", scheme);
          phase::WriteScheme(dir / "horizontal" / "manifest.json", horizontal);
          io::WriteJson(dir / kCaptureSettings, pose_json);
        },
        [&](const fs::path& dir) {
          if (project.manifest.calibration_images > 0) return;
          const fs::path target = scan::ScanLayout{dir}.Target();
          fs::create_directories(target.parent_path());
          util::WriteAtomically(
              target, [&](const fs::path& tmp) { fs::copy_file(options.target_file, tmp); });
        });
    summary.total_s = Seconds(start);
    return summary;
  }
  if (options.board) {
    // A plain image of the board under a white frame from both cameras.
    const auto t0 = Clock::now();
    StackCapture shot = CaptureStack(
        devices.cameras, *devices.projector,
        {cv::Mat(scheme.projector_height, scheme.projector_width, CV_8UC1, cv::Scalar(255))},
        sequence);
    summary.capture_s = Seconds(t0);
    AddStreamStatistics(devices, &summary);
    summary.kind = "board";
    summary.patterns = 1;
    summary.retries = shot.retries;
    summary.frames_failed = shot.frames_failed;
    const int index = project.manifest.calibration_images;
    summary.name = scan::IndexName(index);
    scan::ScanManifest manifest = project.manifest;
    manifest.calibration_images = index + 1;
    manifest.calibration_target = "calibration/target.json";
    const std::string file = summary.name + ".png";
    summary.path = scan::ScanLayout{root}.CalibrationDir(scan::Camera::kLeft) / file;
    CommitView(project, {}, manifest, scheme, nullptr, [&](const fs::path& dir) {
      const scan::ScanLayout l{dir};
      util::OutputTransaction tx;
      for (int c = 0; c < 2; ++c) {
        const fs::path folder =
            l.CalibrationDir(c == 0 ? scan::Camera::kLeft : scan::Camera::kRight);
        fs::create_directories(folder);
        tx.Write(folder / file,
                 [&](const fs::path& tmp) { io::WriteImage(tmp, shot.frames[c][0].image); });
      }
      if (project.manifest.calibration_images == 0) {
        tx.Write(l.Target(), [&](const fs::path& tmp) { fs::copy_file(options.target_file, tmp); });
      }
      tx.Commit();
    });
    summary.total_s = Seconds(start);
    return summary;
  }

  // The fringe stack at every exposure.
  const std::vector<cv::Mat> patterns =
      phase::GeneratePatterns(scheme, scheme.gamma_precompensation);
  std::vector<double> exposures = options.exposures_us;
  if (exposures.empty() || options.auto_exposure) exposures = {settings.exposure_us};
  std::vector<StackCapture> stacks;
  const auto t0 = Clock::now();
  for (size_t e = 0; e < exposures.size(); ++e) {
    if (e > 0) {
      CameraSettings s = settings;
      s.exposure_us = exposures[e];
      for (Camera* c : devices.cameras) {
        c->Stop();
        c->Configure(s);
        c->Start();
      }
    }
    stacks.push_back(CaptureStack(devices.cameras, *devices.projector, patterns, sequence));
    summary.retries += stacks.back().retries;
    summary.frames_failed += stacks.back().frames_failed;
  }
  summary.capture_s = Seconds(t0);
  AddStreamStatistics(devices, &summary);
  summary.kind = "view";
  summary.patterns = static_cast<int>(patterns.size());
  summary.exposures = static_cast<int>(exposures.size());
  const int index = project.manifest.views;
  summary.name = scan::IndexName(index);
  const fs::path relative = fs::path("views") / summary.name;
  summary.path = root / relative;

  settings_json["exposures_us"] = exposures;
  settings_json["cameras"] = json::array();
  for (size_t c = 0; c < devices.cameras.size(); ++c) {
    json cam = ToJson(devices.infos[c]);
    cam["folder"] = camera_names[c];
    cam["exposures"] = json::array();
    for (size_t e = 0; e < stacks.size(); ++e) {
      cam["exposures"].push_back({{"exposure_us", exposures[e]},
                                  {"frames", FrameRecordsToJson(stacks[e].records[c], names)},
                                  {"frames_failed", stacks[e].frames_failed},
                                  {"retries", stacks[e].retry_reasons}});
    }
    settings_json["cameras"].push_back(cam);
  }

  scan::ScanManifest manifest = project.manifest;
  manifest.views = index + 1;
  CommitView(
      project, relative, manifest, scheme,
      [&](const fs::path& dir) {
        for (size_t c = 0; c < devices.cameras.size(); ++c) {
          for (size_t e = 0; e < stacks.size(); ++e) {
            fs::path folder = dir / camera_names[c];
            if (stacks.size() > 1) folder /= StrCat("e", e);
            fs::create_directories(folder);
            for (size_t k = 0; k < names.size(); ++k) {
              io::WriteImage(folder / names[k], stacks[e].frames[c][k].image);
            }
          }
        }
        io::WriteJson(dir / kCaptureSettings, settings_json);
      },
      nullptr);

  if (options.feedback) {
    for (size_t c = 0; c < devices.cameras.size(); ++c) {
      std::vector<cv::Mat> images;
      for (const Frame& f : stacks[0].frames[c]) images.push_back(f.image);
      CameraFeedback f = AssessStack(scheme, images, devices.bit_depth, options.decode);
      f.camera = camera_names[c];
      summary.feedback.push_back(f);
    }
    if (rig_file.empty()) {
      summary.view_message =
          "markers and registration not assessed: no rig (give --rig FILE or put rig.json in the "
          "project)";
    } else {
      ViewFeedbackOptions vo = options.view_feedback;
      vo.reconstruction.decode = options.decode;
      try {
        summary.view = AssessViewIn3D(root, summary.name, rig_file, vo);
      } catch (const Error& e) {
        // The view is captured and kept; only its assessment failed (e.g. a rig for other
        // cameras): the operator is told why.
        summary.view_message = StrCat("markers and registration not assessed: ", e.what());
      }
    }
  }
  summary.total_s = Seconds(start);
  return summary;
}

DeviceList ListDevices(const std::string& display, bool probe_opencv) {
  DeviceList d;
  d.cameras = ListCameras(probe_opencv);
  try {
    d.screens = ListScreens(display);
  } catch (const Error& e) {
    d.screens_error = e.what();
  }
  return d;
}

json ToJson(const DeviceList& d) {
  json j = {{"cameras", json::array()}, {"screens", json::array()}};
  for (const auto& c : d.cameras) j["cameras"].push_back(ToJson(c));
  for (const auto& s : d.screens) j["screens"].push_back(ToJson(s));
  if (!d.screens_error.empty()) j["screens_error"] = d.screens_error;
  return j;
}

}  // namespace fringe::capture
