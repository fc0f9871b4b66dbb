#include "fringe/capture/feedback.h"

#include <chrono>

#include "fringe/io/calibration_io.h"
#include "fringe/io/json.h"
#include "fringe/io/ply.h"
#include "fringe/registration/registration_io.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/stereo/camera_projector.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::capture {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using util::StrCat;

constexpr const char* kCacheDir = ".capture-feedback";  // PROJECT/.capture-feedback/

// A view as the registration takes it: the organized cloud (sensor frame) and its markers.
struct ViewData {
  OrganizedPointCloud cloud;
  std::vector<registration::ViewMarker> markers;
  registration::MarkerDetectionSummary marker_summary;
  bool ok = false;
  std::string message;
};

// The scanner's reconstruction and marker stages on one view of the folder (as
// pipeline::RunScan's per-view step, without its pictures and files).
ViewData ReconstructView(const scan::ScanFolder& folder, const std::string& view,
                         const std::vector<phase::PatternScheme>& schemes, const StereoRig& rig,
                         const stereo::ViewReconstructor& reconstructor,
                         const ViewFeedbackOptions& options) {
  ViewData d;
  stereo::ViewReconstruction rec;
  if (folder.stereo()) {
    rec = reconstructor.Reconstruct(
        folder.ReadExposureStacks(view, scan::Camera::kLeft, schemes.front()),
        folder.ReadExposureStacks(view, scan::Camera::kRight, schemes.front()));
  } else {
    auto stacks = folder.ReadViewStacks(view, scan::Camera::kLeft, schemes);  // [scheme][exposure]
    stereo::ViewStacks in;
    for (auto& exposures : stacks) in.left.push_back(std::move(exposures.front()));
    for (size_t e = 1; e < stacks.front().size(); ++e) {
      for (auto& exposures : stacks) in.more_left_exposures.push_back(std::move(exposures[e]));
    }
    rec = reconstructor.Reconstruct(in);
  }
  if (!rec.summary.ok()) {
    d.message = StrCat("view ", view, ": ", stereo::ToString(rec.summary.status), ": ",
                       rec.summary.message);
    return d;
  }
  registration::ViewMarkers m =
      folder.stereo() ? registration::DetectViewMarkers(rig, rec.texture_left, rec.texture_right,
                                                        rec.cloud, options.markers)
                      : registration::DetectViewMarkersOneCamera(rig.left, rec.texture_left,
                                                                 rec.cloud, options.markers);
  d.cloud = std::move(rec.cloud);
  d.markers = std::move(m.markers);
  d.marker_summary = m.summary;
  d.ok = true;
  return d;
}

// The cache of one project: valid for one rig and set of schemes.
class Cache {
 public:
  Cache(const fs::path& project, const json& key, bool enabled)
      : dir_(project / kCacheDir), enabled_(enabled) {
    if (!enabled_) return;
    std::error_code ec;
    const fs::path key_file = dir_ / "key.json";
    bool valid = false;
    if (fs::is_regular_file(key_file, ec)) {
      try {
        valid = io::ReadJson(key_file) == key;
      } catch (const Error&) {
        valid = false;
      }
    }
    if (!valid) {
      // Made with another rig or scheme (or damaged): start again.
      fs::remove_all(dir_, ec);
      fs::create_directories(dir_, ec);
      if (ec) {
        enabled_ = false;  // an accelerator only: without it every view is reconstructed
        return;
      }
      try {
        io::WriteJson(key_file, key);
      } catch (const Error&) {
        enabled_ = false;
      }
    }
  }
  bool Get(const std::string& view, ViewData* d) const {
    if (!enabled_) return false;
    std::error_code ec;
    const fs::path ply = dir_ / (view + ".ply"), markers = dir_ / (view + ".markers.json");
    if (!fs::is_regular_file(ply, ec) || !fs::is_regular_file(markers, ec)) return false;
    try {
      d->cloud = io::ReadOrganizedPly(ply);
      d->markers = registration::ReadViewMarkers(markers);
      d->ok = true;
      return true;
    } catch (const Error&) {
      return false;  // damaged: reconstructed again
    }
  }
  void Put(const std::string& view, const ViewData& d) const {
    if (!enabled_ || !d.ok) return;
    try {
      // Markers first: an entry counts only when both files exist, and the cloud comes last.
      registration::WriteViewMarkers(dir_ / (view + ".markers.json"), d.markers);
      io::WritePly(dir_ / (view + ".ply"), d.cloud);
    } catch (const Error&) {
      // Not kept: the next capture reconstructs this view again.
    }
  }

 private:
  fs::path dir_;
  bool enabled_;
};

}  // namespace

void ViewFeedbackOptions::Check() const {
  reconstruction.Check();
  markers.Check();
  registration.Check();
}

json ToJson(const ViewFeedback& f) {
  json j = {{"view", f.view},
            {"rig", f.rig_source},
            {"reconstructed", f.reconstructed},
            {"message", f.message},
            {"points", f.points},
            {"markers", f.markers},
            {"rings_left", f.rings_left},
            {"rings_right", f.rings_right},
            {"previous_views", f.previous_views},
            {"seconds", f.seconds}};
  if (f.registration_run) {
    j["registration"] = {
        {"registered", f.registered},        {"path", f.registration_path},
        {"message", f.registration_message}, {"matched_markers", f.matched_markers},
        {"marker_rms_mm", f.marker_rms_mm},  {"overlap_fraction", f.overlap_fraction},
        {"status", f.registration_status}};
  } else {
    j["registration"] = nullptr;
  }
  return j;
}

ViewFeedback AssessViewIn3D(const fs::path& project, const std::string& view,
                            const fs::path& rig_file, const ViewFeedbackOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  options.Check();
  ViewFeedback f;
  f.view = view;
  f.rig_source = rig_file.string();
  const scan::ScanFolder folder = scan::ScanFolder::Open(project);
  const StereoRig rig = io::ReadRig(rig_file);
  const scan::ScanManifest& m = folder.manifest();
  const std::vector<phase::PatternScheme> schemes = folder.ReadSchemes();
  // The rig must be the sensor's: a rig for other images or another projector would give
  // wrong points, not missing ones.
  for (const CameraModel* cam : {&rig.left, folder.stereo() ? &rig.right : nullptr}) {
    if (cam && (cam->width != m.image_width || cam->height != m.image_height)) {
      throw Error(StrCat(rig_file.string(), ": a camera is calibrated at ", cam->width, " x ",
                         cam->height, " px, but ", folder.layout().Manifest().string(),
                         " says the images are ", m.image_width, " x ", m.image_height));
    }
  }
  if (!folder.stereo()) {
    if (!rig.projector) {
      throw Error(StrCat(rig_file.string(),
                         ": the rig has no calibrated projector, which a camera + projector "
                         "folder needs (fringe calibrate on board poses captured with --board)"));
    }
    for (const auto& s : schemes) {
      if (!stereo::SchemeFitsProjector(s, *rig.projector)) {
        throw Error(StrCat(rig_file.string(), ": calibrates a ", rig.projector->width, " x ",
                           rig.projector->height, " projector, but the scheme '", s.name,
                           "' is for ", s.projector_width, " x ", s.projector_height));
      }
    }
  }
  const stereo::ViewReconstructor reconstructor =
      folder.stereo()
          ? stereo::ViewReconstructor(rig, schemes.front(), options.reconstruction)
          : stereo::MakeCameraProjectorReconstructor(
                stereo::CameraProjectorRig::FromLeftCamera(rig), schemes, options.reconstruction);
  json key = {{"rig", io::RigToJson(rig)}, {"schemes", json::array()}};
  for (const auto& s : schemes) key["schemes"].push_back(phase::SchemeToJson(s));
  const Cache cache(project, key, options.cache);

  // The new view, measured now (never from the cache: its images are new).
  const ViewData now = ReconstructView(folder, view, schemes, rig, reconstructor, options);
  f.reconstructed = now.ok;
  if (!now.ok) {
    f.message = now.message;
    f.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return f;
  }
  cache.Put(view, now);
  f.points = static_cast<int>(now.cloud.NumValid());
  f.markers = static_cast<int>(now.markers.size());
  f.rings_left = now.marker_summary.rings_left;
  f.rings_right = now.marker_summary.rings_right;

  // The previous views, from the cache or reconstructed.
  std::vector<registration::RegistrationView> inputs;
  for (const std::string& name : folder.views()) {
    if (name == view) continue;
    ViewData d;
    if (!cache.Get(name, &d)) {
      d = ReconstructView(folder, name, schemes, rig, reconstructor, options);
      cache.Put(name, d);
    }
    if (!d.ok) continue;  // a view that does not reconstruct cannot be registered to
    registration::RegistrationView rv;
    rv.name = name;
    rv.cloud = d.cloud.Compact();
    rv.grid = registration::IndexViewGrid(d.cloud);
    rv.markers = std::move(d.markers);
    inputs.push_back(std::move(rv));
  }
  f.previous_views = static_cast<int>(inputs.size());
  if (inputs.empty()) {
    f.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return f;
  }
  registration::RegistrationView rv;
  rv.name = view;
  rv.cloud = now.cloud.Compact();
  rv.grid = registration::IndexViewGrid(now.cloud);
  rv.markers = now.markers;
  inputs.push_back(std::move(rv));
  const registration::RegistrationResult r =
      registration::RegisterViews(inputs, options.registration);
  const registration::ViewRegistration& last = r.views.back();
  f.registration_run = true;
  f.registered = last.placed();
  f.registration_path = registration::ToString(last.path);
  f.registration_message = last.message;
  f.matched_markers = last.matched_markers;
  f.marker_rms_mm = last.marker_rms_mm;
  f.overlap_fraction = last.overlap_fraction;
  f.registration_status = registration::ToString(r.summary.status);
  f.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return f;
}

}  // namespace fringe::capture
