#include "fringe/pipeline/reconstruct.h"

#include <cmath>
#include <utility>

#include "fringe/io/image_io.h"
#include "fringe/io/ply.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/stack_io.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/stereo/camera_projector.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::pipeline {
namespace {

namespace fs = std::filesystem;
using util::StrCat;

// The first existing candidate, or an error naming what was looked for.
fs::path FirstExisting(const std::vector<fs::path>& candidates, const char* what,
                       const char* flag) {
  for (const auto& c : candidates) {
    if (fs::exists(c)) return c;
  }
  std::string tried;
  for (const auto& c : candidates) tried += " " + c.string();
  throw Error(StrCat("reconstruct: no ", what, " given (", flag, ") and none found at", tried));
}

// Where the view's inputs are: its image folders, its scheme(s) and the default calibration.
struct ViewInputs {
  fs::path left_dir, right_dir;
  bool have_right_dir = false;
  bool two_directions = false;  // left/vertical/ + left/horizontal/
  std::optional<fs::path> scan_root;
  std::optional<std::pair<fs::path, fs::path>> scan_schemes;  // a scan's two directions
  std::string scheme_arg;             // the (vertical) scheme: a file or a preset name
  std::vector<fs::path> default_rig;  // the rig JSON beside the view, when no files are given
};

ViewInputs FindInputs(const fs::path& view, const ReconstructFolderOptions& options) {
  ViewInputs in;
  // left/ and right/ (fringe's layout) or L/ and R/ (common in other tools' captures).
  in.left_dir = view / "left";
  in.right_dir = view / "right";
  if (!fs::is_directory(in.left_dir) && fs::is_directory(view / "L")) {
    in.left_dir = view / "L";
    in.right_dir = view / "R";
  }
  in.have_right_dir = fs::is_directory(in.right_dir);
  const bool two_cameras_required =
      options.mode == ReconstructMode::kStereo || options.mode == ReconstructMode::kTrinocular;
  if (!fs::is_directory(in.left_dir) || (two_cameras_required && !in.have_right_dir)) {
    throw Error(StrCat(
        "reconstruct: ", view.string(), " must contain left/ ",
        two_cameras_required ? "and right/ (or L/ and R/) image folders" : "(or L/) images"));
  }
  // Both fringe directions: left/vertical/ and left/horizontal/, each with its manifest
  // (the layout of the projector calibration's pose folders, docs/scan-folder.md).
  in.two_directions =
      fs::is_directory(in.left_dir / "vertical") && fs::is_directory(in.left_dir / "horizontal");
  if (in.two_directions && !options.scheme.empty()) {
    throw Error(StrCat("reconstruct: ", in.left_dir.string(),
                       " holds vertical/ and horizontal/ stacks whose schemes are their "
                       "manifest.json files; --scheme does not apply"));
  }
  // In a scan folder (ROOT/views/NNN) the scheme is the one its manifest names; elsewhere a
  // manifest beside the images. A scan folder's view with both directions: the schemes are the
  // scan's (scan.json's scheme and scheme_horizontal), not manifests beside the stacks.
  in.scan_root = scan::ScanFolder::RootOfView(view);
  if (in.two_directions && in.scan_root) {
    const scan::ScanFolder folder = scan::ScanFolder::Open(*in.scan_root);
    if (folder.both_directions()) {
      in.scan_schemes = {*in.scan_root / folder.manifest().scheme,
                         *in.scan_root / folder.manifest().scheme_horizontal};
    }
  }
  in.scheme_arg =
      in.scan_schemes           ? in.scan_schemes->first.string()
      : in.two_directions       ? (in.left_dir / "vertical" / "manifest.json").string()
      : !options.scheme.empty() ? options.scheme
      : in.scan_root
          ? (*in.scan_root / scan::ScanFolder::Open(*in.scan_root).manifest().scheme).string()
          : FirstExisting({view / "manifest.json", view / "left" / "manifest.json",
                           view.parent_path() / "manifest.json"},
                          "scheme manifest", "--scheme")
                .string();
  // Without a calibration given, the rig JSON beside the view (looked for now: its absence is
  // an error before any work).
  if (options.empty()) {
    in.default_rig = {FirstExisting({view / "rig.json", view.parent_path() / "rig.json"},
                                    "calibration", "--calib")};
  }
  return in;
}

// Output locations first (before minutes of work), never onto an input.
void CheckOutputs(const fs::path& view, const fs::path& cloud, const fs::path& markers_file,
                  const ViewInputs& in, const ReconstructFolderOptions& options) {
  const fs::path& residuals = options.residuals;
  if (!residuals.empty() && !util::HasExtension(residuals, {".tif", ".tiff"})) {
    throw Error(StrCat(residuals.string(),
                       ": --residuals writes 32-bit float values; use a .tif or .tiff "
                       "name (other formats would truncate them)"));
  }
  std::vector<fs::path> inputs = {view, in.scheme_arg};
  for (const std::vector<fs::path>& files : {options.Files(), in.default_rig}) {
    inputs.insert(inputs.end(), files.begin(), files.end());
  }
  util::CheckOutputFile(cloud, inputs);
  // The cloud is always PLY, and fringe tells files apart by the extension (fringe info refuses
  // a cloud named otherwise): refused here, before any work, not written under a name nothing
  // reads back. After the output rule, so that an --out naming an input is reported as that.
  if (!util::HasExtension(cloud, {".ply"})) {
    throw Error(StrCat(cloud.string(), ": --out writes a PLY point cloud; use a .ply name"));
  }
  if (!residuals.empty()) {
    util::CheckOutputFile(residuals, inputs);
    util::CheckDistinctOutputs({cloud, residuals});
  }
  if (options.detect_markers) {
    util::CheckOutputFile(markers_file, inputs);
    util::CheckDistinctOutputs({cloud, residuals, markers_file});
  }
}

// The schemes (one, or vertical + horizontal) and the left camera's stacks.
struct LeftStacks {
  std::vector<phase::PatternScheme> schemes;
  std::vector<fs::path> dirs;  // the folder of each scheme's stack
  // One stack per scheme, each folder a stack or exposure folders e0/, e1/, ... (phase/
  // stack_io.h; the same number for both directions), combined per pixel by the decoder.
  // more: the further exposures, exposure-major (stereo::ViewStacks).
  std::vector<std::vector<cv::Mat>> stacks, exposures, more;
};

LeftStacks ReadLeft(const ViewInputs& in, const ReconstructFolderOptions& options) {
  LeftStacks l;
  l.schemes = {phase::SchemeFromArgument(in.scheme_arg, options.parameters)};
  l.dirs = {in.two_directions ? in.left_dir / "vertical" : in.left_dir};
  if (!in.two_directions) {
    l.exposures = phase::ReadExposureStacks(in.left_dir, l.schemes[0]);
    l.stacks = {l.exposures.front()};
    l.more.assign(l.exposures.begin() + 1, l.exposures.end());
    return l;
  }
  const fs::path horizontal_scheme =
      in.scan_schemes ? in.scan_schemes->second : in.left_dir / "horizontal" / "manifest.json";
  l.schemes.push_back(phase::ReadScheme(horizontal_scheme));
  l.dirs.push_back(in.left_dir / "horizontal");
  // Name the file the wrong scheme came from (the scan's scheme file or the stack's own
  // manifest) and the folder it was meant for.
  const std::string sources[] = {in.scheme_arg, horizontal_scheme.string()};
  const char* names[] = {"vertical", "horizontal"};
  const phase::FringeDirection wanted[] = {phase::FringeDirection::kVertical,
                                           phase::FringeDirection::kHorizontal};
  for (int k = 0; k < 2; ++k) {
    if (l.schemes[k].direction != wanted[k]) {
      throw Error(StrCat(sources[k], ": scheme '", l.schemes[k].name, "' has ",
                         phase::DirectionName(l.schemes[k].direction), " fringes; ",
                         l.dirs[k].string(), " needs ", names[k], " ones"));
    }
  }
  std::vector<std::vector<std::vector<cv::Mat>>> per_scheme;
  for (size_t k = 0; k < l.schemes.size(); ++k) {
    per_scheme.push_back(phase::ReadExposureStacks(l.dirs[k], l.schemes[k]));
    if (per_scheme[k].size() != per_scheme[0].size()) {
      throw Error(StrCat(l.dirs[k].string(), ": ", per_scheme[k].size(), " exposures, but ",
                         l.dirs[0].string(), " holds ", per_scheme[0].size()));
    }
    l.stacks.push_back(per_scheme[k][0]);
  }
  for (size_t e = 1; e < per_scheme[0].size(); ++e) {
    for (auto& exposures : per_scheme) l.more.push_back(exposures[e]);
  }
  l.exposures = per_scheme[0];
  return l;
}

// The mode the view and the rig allow, checked against the rig and the schemes.
ReconstructMode ResolveMode(const ViewInputs& in, const LeftStacks& l, const ResolvedRig& resolved,
                            ReconstructMode requested) {
  const StereoRig& rig = resolved.rig;
  const ReconstructMode mode = requested != ReconstructMode::kAuto ? requested
                               : in.have_right_dir && rig.BaselineMm() > 0 && !in.two_directions
                                   ? ReconstructMode::kStereo
                                   : ReconstructMode::kCameraProjector;
  const bool needs_projector =
      mode == ReconstructMode::kCameraProjector || mode == ReconstructMode::kTrinocular;
  if (needs_projector && !rig.projector) {
    throw Error(StrCat("reconstruct: ", resolved.source,
                       requested == ReconstructMode::kAuto
                           ? ": the view has no right/ images or the rig no right camera, and"
                           : ":",
                       " the rig has no calibrated projector for ", ToString(requested), " mode"));
  }
  // The scheme and the rig both describe the projector: a scheme made for another projector
  // decodes to columns of that one, and the points come out wrong, not missing.
  if (needs_projector) {
    for (size_t k = 0; k < l.schemes.size(); ++k) {
      const phase::PatternScheme& s = l.schemes[k];
      if (!stereo::SchemeFitsProjector(s, *rig.projector)) {
        throw Error(StrCat("reconstruct: ", k == 0 ? in.scheme_arg : l.dirs[k].string(),
                           ": the scheme '", s.name, "' is for a ", s.projector_width, " x ",
                           s.projector_height, " projector, but ", resolved.source,
                           " calibrates a ", rig.projector->width, " x ", rig.projector->height,
                           " projector; give the scheme the patterns were made with and the "
                           "rig of that projector"));
      }
    }
  }
  if (mode != ReconstructMode::kCameraProjector && in.two_directions) {
    throw Error(StrCat("reconstruct: ", in.left_dir.string(),
                       ": vertical/ and horizontal/ stacks are read in camera-projector mode "
                       "only (stereo matching uses vertical fringes)"));
  }
  return mode;
}

// Images of another size than the rig's camera: name the folder (the reconstructor cannot).
void RequireSize(const std::vector<cv::Mat>& images, const CameraModel& camera, const fs::path& dir,
                 const std::string& rig_source) {
  if (!images.empty() && (images[0].cols != camera.width || images[0].rows != camera.height)) {
    throw Error(StrCat(dir.string(), ": images are ", images[0].cols, "x", images[0].rows,
                       " but the camera of ", rig_source, " is ", camera.width, "x",
                       camera.height));
  }
}

}  // namespace

const char* ToString(ReconstructMode m) {
  switch (m) {
    case ReconstructMode::kAuto:
      return "auto";
    case ReconstructMode::kStereo:
      return "stereo";
    case ReconstructMode::kCameraProjector:
      return "camera-projector";
    case ReconstructMode::kTrinocular:
      return "trinocular";
  }
  return "?";
}

ReconstructMode ReconstructModeFromString(const std::string& name) {
  for (ReconstructMode m : {ReconstructMode::kAuto, ReconstructMode::kStereo,
                            ReconstructMode::kCameraProjector, ReconstructMode::kTrinocular}) {
    if (name == ToString(m)) return m;
  }
  throw Error(StrCat("reconstruct mode '", name,
                     "': expected auto, stereo, camera-projector or trinocular"));
}

void ReconstructFolderOptions::Check() const {
  CalibrationFiles::Check("reconstruct");
  util::CheckOption(bit_depth >= 0 && bit_depth <= 16, "ReconstructFolderOptions", "bit_depth",
                    bit_depth, "must be in [0, 16] (0: from the scan folder or the images)");
  reconstruction.Check();
}

nlohmann::json ToJson(const ViewFolderReconstruction& r) {
  nlohmann::json j = {{"view", r.view.string()},
                      {"mode", ToString(r.mode)},
                      {"out", r.cloud.string()},
                      {"summary", stereo::ToJson(r.reconstruction.summary)}};
  if (r.markers) {
    j["markers"] = {{"file", r.markers_file.string()},
                    {"count", r.markers->markers.size()},
                    {"report", r.markers->summary.BriefReport()}};
  }
  return j;
}

ViewFolderReconstruction ReconstructViewFolder(const fs::path& view, const fs::path& cloud,
                                               const ReconstructFolderOptions& options) {
  options.Check();
  const ViewInputs in = FindInputs(view, options);
  ViewFolderReconstruction r;
  r.view = view;
  r.cloud = cloud;
  r.residuals = options.residuals;
  r.two_directions = in.two_directions;
  if (options.detect_markers) r.markers_file = registration::MarkersPathForCloud(cloud);
  CheckOutputs(view, cloud, r.markers_file, in, options);

  const LeftStacks l = ReadLeft(in, options);
  const phase::PatternScheme& scheme = l.schemes[0];
  const std::vector<cv::Mat>& left = l.stacks[0];
  // The scheme's projector size stands in when a file does not hold it (SLMaster).
  RigReadOptions read;
  read.devices = options.mode == ReconstructMode::kStereo ? RigDevices::kStereo
                 : options.mode == ReconstructMode::kAuto && in.have_right_dir
                     ? RigDevices::kAuto
                     : RigDevices::kCameraProjector;
  read.camera_width = left.at(0).cols;
  read.camera_height = left.at(0).rows;
  read.projector_width = scheme.projector_width;
  read.projector_height = scheme.projector_height;
  const ResolvedRig resolved = *LookUpRig(options, read, in.default_rig);
  const StereoRig& rig = resolved.rig;
  r.rig_source = resolved.source;
  r.mode = ResolveMode(in, l, resolved, options.mode);
  const bool camera_projector = r.mode == ReconstructMode::kCameraProjector;
  if (camera_projector) {
    r.report.push_back(StrCat("camera-projector mode: ", in.left_dir.string(),
                              in.two_directions ? " (vertical and horizontal fringes)" : "",
                              " against the projector of ", resolved.source));
  }
  const auto right_exposures = camera_projector ? std::vector<std::vector<cv::Mat>>{}
                                                : phase::ReadExposureStacks(in.right_dir, scheme);
  RequireSize(left, rig.left, in.left_dir, resolved.source);
  if (!camera_projector)
    RequireSize(right_exposures.front(), rig.right, in.right_dir, resolved.source);

  stereo::ReconstructionOptions ro = options.reconstruction;
  // In a scan folder the full scale follows the bit depth its manifest states.
  const int bit_depth = options.bit_depth == 0 && in.scan_root
                            ? scan::ScanFolder::Open(*in.scan_root).manifest().bit_depth
                            : options.bit_depth;
  if (bit_depth > 0) ro.decode.full_scale_dn = std::ldexp(1.0, bit_depth) - 1;
  stereo::ViewReconstruction& rec = r.reconstruction;
  const stereo::ReconstructionSummary& s = rec.summary;
  if (camera_projector) {
    stereo::ViewStacks stacks{l.stacks, {}};
    stacks.more_left_exposures = l.more;
    rec = stereo::MakeCameraProjectorReconstructor(stereo::CameraProjectorRig::FromLeftCamera(rig),
                                                   l.schemes, ro)
              .Reconstruct(stacks);
    r.report.push_back(s.decode_left.BriefReport() +
                       (in.two_directions ? " (camera, vertical)" : " (camera)"));
    if (in.two_directions)
      r.report.push_back(s.decode_right.BriefReport() + " (camera, horizontal)");
    r.report.push_back(s.matching.BriefReport());
    phase::WarnIfSchemeMismatch(s.decode_left, scheme.name, l.dirs[0].string());
    if (in.two_directions) {
      phase::WarnIfSchemeMismatch(s.decode_right, l.schemes[1].name, l.dirs[1].string());
    }
  } else {
    rec =
        r.mode == ReconstructMode::kTrinocular
            ? stereo::ViewReconstructor(stereo::MakeTrinocularCorrespondence(rig, ro.matching),
                                        {scheme}, ro)
                  .Reconstruct(l.exposures, right_exposures)
            : stereo::ViewReconstructor(rig, scheme, ro).Reconstruct(l.exposures, right_exposures);
    r.report.push_back(s.decode_left.BriefReport() + " (left)");
    r.report.push_back(s.decode_right.BriefReport() + " (right)");
    r.report.push_back(s.matching.BriefReport());
    phase::WarnIfSchemeMismatch(s.decode_left, scheme.name, in.left_dir.string());
    phase::WarnIfSchemeMismatch(s.decode_right, scheme.name, in.right_dir.string());
  }
  if (ro.remove_outliers) r.report.push_back(s.outliers.BriefReport());
  if (ro.compute_normals) r.report.push_back(s.normals.BriefReport());
  r.report.push_back(s.BriefReport());
  if (!s.ok()) {
    // Name the calibration too: a wrong or foreign rig is the usual cause of no points.
    throw Error(StrCat("reconstruct: ", view.string(), ": ", stereo::ToString(s.status), ": ",
                       s.message, " (calibration ", resolved.source, ")"));
  }

  // The cloud, the residual image and the markers are committed together or not at all.
  util::OutputTransaction outputs;
  outputs.Write(cloud, [&](const fs::path& tmp) {
    io::WritePly(tmp, rec.cloud,
                 options.ascii_ply ? io::PlyFormat::kAscii : io::PlyFormat::kBinaryLittleEndian,
                 {camera_projector
                      ? "fringe reconstruct (camera-projector): camera frame, mm; quality = "
                        "fringe modulation (DN), intensity = texture, residual_px = round trip "
                        "into the projector (px)"
                      : "fringe reconstruct: left camera frame, mm; quality = fringe modulation "
                        "(DN), intensity = texture, residual_px = reprojection residual (px)"});
  });
  if (!options.residuals.empty()) {
    outputs.Write(options.residuals,
                  [&](const fs::path& tmp) { io::WriteImage(tmp, rec.reprojection_error_px); });
  }
  // Stereo: markers triangulated from both cameras' textures; one camera: its ring centre's ray
  // against the measured surface.
  if (options.detect_markers) {
    r.markers =
        camera_projector
            ? registration::DetectViewMarkersOneCamera(rig.left, rec.texture_left, rec.cloud)
            : registration::DetectViewMarkers(rig, rec.texture_left, rec.texture_right, rec.cloud);
    outputs.Write(r.markers_file, [&](const fs::path& tmp) {
      registration::WriteViewMarkers(tmp, r.markers->markers);
    });
  }
  outputs.Commit();
  return r;
}

}  // namespace fringe::pipeline
