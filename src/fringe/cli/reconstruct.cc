// fringe reconstruct: one view (left/ and right/ fringe image stacks, or one camera's stack with a
// calibrated projector) -> organized point cloud.
#include <CLI/CLI.hpp>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "fringe/cli/calibration_flags.h"
#include "fringe/cli/cli.h"
#include "fringe/cli/scheme_flags.h"
#include "fringe/io/image_io.h"
#include "fringe/io/ply.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/stack_io.h"
#include "fringe/registration/markers.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/stereo/camera_projector.h"
#include "fringe/stereo/reconstruct_view.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/log.h"

namespace fringe::cli {
namespace {

namespace fs = std::filesystem;

// The first existing candidate, or an error naming what was looked for.
fs::path FirstExisting(const std::vector<fs::path>& candidates, const char* what,
                       const char* flag) {
  for (const auto& c : candidates) {
    if (fs::exists(c)) return c;
  }
  std::string tried;
  for (const auto& c : candidates) tried += " " + c.string();
  throw Error(
      util::StrCat("reconstruct: no ", what, " given (", flag, ") and none found at", tried));
}

}  // namespace

void AddReconstructCommand(CLI::App& app) {
  struct Args {
    std::string view;
    pipeline::CalibrationFiles calibration;
    std::string scheme;
    std::string out;
    std::string residuals;
    std::string mode = "auto";
    bool ascii = false;
    bool no_normals = false;
    bool keep_outliers = false;
    bool no_markers = false;
    bool json = false;
    int bit_depth = 0;
    stereo::ReconstructionOptions options;
    phase::SchemeParameters parameters;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "reconstruct",
      "Reconstruct one view: decode left/ and right/ fringe images, match the absolute phase, "
      "triangulate to an organized point cloud (left camera frame, PLY) with normals; or, with "
      "one camera's images and a calibrated projector, triangulate camera against projector");
  sub->add_option("view", a->view,
                  "View folder with left/ and right/ (or L/ and R/) image stacks (each may hold "
                  "exposure folders e0/, e1/, ...); left/ (or L/) alone in camera-projector mode, "
                  "where left/vertical/ and left/horizontal/ (each with its manifest.json) give "
                  "both fringe directions")
      ->required();
  sub->add_option("--mode", a->mode,
                  "stereo (two cameras), camera-projector (left camera + the rig's projector: "
                  "the camera ray meets the projector's column, or row for horizontal fringes, "
                  "in the distorted projector model; both directions: two-ray triangulation), "
                  "trinocular (stereo, plus the left pixels the right camera cannot see from "
                  "the left camera + projector), or auto: stereo when the view has right/ "
                  "images and the rig a right camera, else camera-projector")
      ->check(CLI::IsMember({"stereo", "camera-projector", "trinocular", "auto"}))
      ->capture_default_str();
  AddCalibrationFlags(sub, &a->calibration, "VIEW/rig.json or VIEW/../rig.json");
  sub->add_option("--scheme", a->scheme,
                  "Scheme manifest or preset name; default: in a scan folder the scheme its "
                  "scan.json names, else VIEW/manifest.json, VIEW/left/manifest.json or "
                  "VIEW/../manifest.json");
  AddSchemeFlags(sub, &a->parameters);
  sub->add_option("--out", a->out,
                  "Output PLY, a .ply name (organized: keeps the left camera grid)")
      ->required();
  sub->add_option("--residuals", a->residuals,
                  "Also write the per-pixel reprojection residual (32-bit float TIFF, pixels)");
  sub->add_option("--noise-sigma", a->options.decode.noise_sigma_dn,
                  "Camera noise in DN (sets the decoder's modulation threshold); 0 estimates it "
                  "from the images' least-squares residual")
      ->capture_default_str();
  sub->add_option("--min-modulation", a->options.decode.min_modulation_dn,
                  "Fringe modulation threshold in DN (0: from the noise and the scheme)")
      ->capture_default_str();
  sub->add_option("--bit-depth", a->bit_depth,
                  "Significant bits of the images (e.g. 12 for 12-bit data in 16-bit PNGs): the "
                  "full scale for saturation, exposure and texture; default from the scan "
                  "folder's scan.json, else the image container's (8 or 16)")
      ->check(CLI::Range(1, 16));
  sub->add_option("--gamma", a->options.decode.projector_gamma,
                  "Measured projector gamma (0: unknown). The decoder corrects only what the "
                  "scheme's gamma_precompensation did not: gamma / gamma_precompensation")
      ->capture_default_str();
  sub->add_option("--max-reprojection", a->options.matching.max_reprojection_error_px,
                  "Drop points with a larger reprojection residual (pixels)")
      ->capture_default_str();
  sub->add_option("--max-projector-error", a->options.matching.max_projector_error_px,
                  "Projector consistency tolerance in projector pixels (0: off; needs a "
                  "calibrated projector in the rig)")
      ->capture_default_str();
  sub->add_flag("--no-normals", a->no_normals, "Do not estimate normals");
  sub->add_flag("--keep-outliers", a->keep_outliers, "Do not remove flying pixels / small patches");
  sub->add_flag("--ascii", a->ascii, "Write ASCII PLY");
  sub->add_flag("--json", a->json,
                "Print every stage's summary as one JSON object instead of the text report");
  sub->add_flag("--no-markers", a->no_markers,
                "Do not detect sticky markers (default: OUT.markers.json beside the cloud)");
  sub->callback([a] {
    const fs::path view(a->view);
    // left/ and right/ (fringe's layout) or L/ and R/ (common in other tools' captures).
    fs::path left_dir = view / "left", right_dir = view / "right";
    if (!fs::is_directory(left_dir) && fs::is_directory(view / "L")) {
      left_dir = view / "L";
      right_dir = view / "R";
    }
    const bool have_right_dir = fs::is_directory(right_dir);
    const bool two_cameras_required = a->mode == "stereo" || a->mode == "trinocular";
    if (!fs::is_directory(left_dir) || (two_cameras_required && !have_right_dir)) {
      throw Error(util::StrCat(
          "reconstruct: ", view.string(), " must contain left/ ",
          two_cameras_required ? "and right/ (or L/ and R/) image folders" : "(or L/) images"));
    }
    // Both fringe directions: left/vertical/ and left/horizontal/, each with its manifest
    // (the layout of the projector calibration's pose folders, docs/scan-folder.md).
    const bool two_directions =
        fs::is_directory(left_dir / "vertical") && fs::is_directory(left_dir / "horizontal");
    if (two_directions && !a->scheme.empty()) {
      throw Error(util::StrCat("reconstruct: ", left_dir.string(),
                               " holds vertical/ and horizontal/ stacks whose schemes are their "
                               "manifest.json files; --scheme does not apply"));
    }
    // In a scan folder (ROOT/views/NNN) the scheme is the one its manifest names; elsewhere a
    // manifest beside the images.
    const std::optional<fs::path> scan_root = scan::ScanFolder::RootOfView(view);
    // A scan folder's view with both directions: the schemes are the scan's (scan.json's
    // scheme and scheme_horizontal), not manifests beside the stacks.
    std::optional<std::pair<fs::path, fs::path>> scan_schemes;
    if (two_directions && scan_root) {
      const scan::ScanFolder folder = scan::ScanFolder::Open(*scan_root);
      if (folder.both_directions()) {
        scan_schemes = {*scan_root / folder.manifest().scheme,
                        *scan_root / folder.manifest().scheme_horizontal};
      }
    }
    const std::string scheme_arg =
        scan_schemes         ? scan_schemes->first.string()
        : two_directions     ? (left_dir / "vertical" / "manifest.json").string()
        : !a->scheme.empty() ? a->scheme
        : scan_root ? (*scan_root / scan::ScanFolder::Open(*scan_root).manifest().scheme).string()
                    : FirstExisting({view / "manifest.json", view / "left" / "manifest.json",
                                     view.parent_path() / "manifest.json"},
                                    "scheme manifest", "--scheme")
                          .string();
    const pipeline::CalibrationFiles& calibration = a->calibration;
    calibration.Check("reconstruct");
    // Without a calibration given, the rig JSON beside the view (looked for now: its absence
    // is an error before any work).
    const std::vector<fs::path> default_rig =
        calibration.empty()
            ? std::vector<fs::path>{FirstExisting(
                  {view / "rig.json", view.parent_path() / "rig.json"}, "calibration", "--calib")}
            : std::vector<fs::path>{};
    // Output locations first (before minutes of work), never onto an input.
    if (!a->residuals.empty() && !util::HasExtension(a->residuals, {".tif", ".tiff"})) {
      throw Error(util::StrCat(a->residuals,
                               ": --residuals writes 32-bit float values; use a .tif or .tiff "
                               "name (other formats would truncate them)"));
    }
    std::vector<fs::path> inputs = {view, scheme_arg};
    for (const std::vector<fs::path>& files : {calibration.Files(), default_rig}) {
      inputs.insert(inputs.end(), files.begin(), files.end());
    }
    util::CheckOutputFile(a->out, inputs);
    // The cloud is always PLY, and fringe tells files apart by the extension (fringe info
    // refuses a cloud named otherwise): refused here, before any work, not written under a name
    // nothing reads back. After the output rule, so that an --out naming an input is reported
    // as that.
    if (!util::HasExtension(a->out, {".ply"})) {
      throw Error(util::StrCat(a->out, ": --out writes a PLY point cloud; use a .ply name"));
    }
    if (!a->residuals.empty()) {
      util::CheckOutputFile(a->residuals, inputs);
      util::CheckDistinctOutputs({a->out, a->residuals});
    }
    const fs::path markers_path = registration::MarkersPathForCloud(a->out);
    if (!a->no_markers) {
      util::CheckOutputFile(markers_path, inputs);
      util::CheckDistinctOutputs({a->out, a->residuals, markers_path});
    }
    std::vector<phase::PatternScheme> schemes = {
        phase::SchemeFromArgument(scheme_arg, a->parameters)};
    std::vector<fs::path> left_dirs = {two_directions ? left_dir / "vertical" : left_dir};
    if (two_directions) {
      const fs::path horizontal_scheme =
          scan_schemes ? scan_schemes->second : left_dir / "horizontal" / "manifest.json";
      schemes.push_back(phase::ReadScheme(horizontal_scheme));
      left_dirs.push_back(left_dir / "horizontal");
      // Name the file the wrong scheme came from (the scan's scheme file or the stack's own
      // manifest) and the folder it was meant for.
      const std::string sources[] = {scheme_arg, horizontal_scheme.string()};
      const char* names[] = {"vertical", "horizontal"};
      const phase::FringeDirection wanted[] = {phase::FringeDirection::kVertical,
                                               phase::FringeDirection::kHorizontal};
      for (int k = 0; k < 2; ++k) {
        if (schemes[k].direction != wanted[k]) {
          throw Error(util::StrCat(sources[k], ": scheme '", schemes[k].name, "' has ",
                                   phase::DirectionName(schemes[k].direction), " fringes; ",
                                   left_dirs[k].string(), " needs ", names[k], " ones"));
        }
      }
    }
    const phase::PatternScheme& scheme = schemes[0];
    // One stack per scheme, each folder a stack or exposure folders e0/, e1/, ...
    // (phase/stack_io.h; the same number for both directions), combined per pixel by the
    // decoder. more_left: the further exposures, exposure-major (stereo::ViewStacks).
    std::vector<std::vector<cv::Mat>> left_stacks, left_exposures, more_left;
    if (two_directions) {
      std::vector<std::vector<std::vector<cv::Mat>>> per_scheme;
      for (size_t k = 0; k < schemes.size(); ++k) {
        per_scheme.push_back(phase::ReadExposureStacks(left_dirs[k], schemes[k]));
        if (per_scheme[k].size() != per_scheme[0].size()) {
          throw Error(util::StrCat(left_dirs[k].string(), ": ", per_scheme[k].size(),
                                   " exposures, but ", left_dirs[0].string(), " holds ",
                                   per_scheme[0].size()));
        }
        left_stacks.push_back(per_scheme[k][0]);
      }
      for (size_t e = 1; e < per_scheme[0].size(); ++e) {
        for (auto& exposures : per_scheme) more_left.push_back(exposures[e]);
      }
      left_exposures = per_scheme[0];
    } else {
      left_exposures = phase::ReadExposureStacks(left_dir, scheme);
      left_stacks = {left_exposures.front()};
      more_left.assign(left_exposures.begin() + 1, left_exposures.end());
    }
    const std::vector<cv::Mat>& left = left_stacks[0];
    // The scheme's projector size stands in when a file does not hold it (SLMaster).
    pipeline::RigReadOptions read;
    read.devices = a->mode == "stereo"                   ? pipeline::RigDevices::kStereo
                   : a->mode == "auto" && have_right_dir ? pipeline::RigDevices::kAuto
                                                         : pipeline::RigDevices::kCameraProjector;
    read.camera_width = left.at(0).cols;
    read.camera_height = left.at(0).rows;
    read.projector_width = scheme.projector_width;
    read.projector_height = scheme.projector_height;
    const pipeline::ResolvedRig resolved = *pipeline::LookUpRig(calibration, read, default_rig);
    const StereoRig& rig = resolved.rig;
    const std::string& rig_name = resolved.source;
    const bool camera_projector =
        a->mode == "camera-projector" ||
        (a->mode == "auto" && !(have_right_dir && rig.BaselineMm() > 0 && !two_directions));
    const bool trinocular = a->mode == "trinocular";
    if ((camera_projector || trinocular) && !rig.projector) {
      throw Error(util::StrCat("reconstruct: ", rig_name,
                               a->mode == "auto" ? ": the view has no right/ images or the rig "
                                                   "no right camera, and"
                                                 : ":",
                               " the rig has no calibrated projector for ", a->mode, " mode"));
    }
    // The scheme and the rig both describe the projector: a scheme made for another projector
    // decodes to columns of that one, and the points come out wrong, not missing.
    if ((camera_projector || trinocular) && rig.projector) {
      for (size_t k = 0; k < schemes.size(); ++k) {
        const phase::PatternScheme& s = schemes[k];
        if (!stereo::SchemeFitsProjector(s, *rig.projector)) {
          throw Error(util::StrCat("reconstruct: ", k == 0 ? scheme_arg : left_dirs[k].string(),
                                   ": the scheme '", s.name, "' is for a ", s.projector_width,
                                   " x ", s.projector_height, " projector, but ", rig_name,
                                   " calibrates a ", rig.projector->width, " x ",
                                   rig.projector->height,
                                   " projector; give the scheme the patterns were made with "
                                   "and the rig of that projector"));
        }
      }
    }
    if (!camera_projector && two_directions) {
      throw Error(util::StrCat("reconstruct: ", left_dir.string(),
                               ": vertical/ and horizontal/ stacks are read in camera-projector "
                               "mode only (stereo matching uses vertical fringes)"));
    }
    // With --json the text report is dropped so that stdout is one JSON object.
    std::ostringstream dropped;
    std::ostream& text = a->json ? dropped : std::cout;
    if (camera_projector) {
      text << "camera-projector mode: " << left_dir.string()
           << (two_directions ? " (vertical and horizontal fringes)" : "")
           << " against the projector of " << rig_name << "\n";
    }
    const auto right_exposures = camera_projector ? std::vector<std::vector<cv::Mat>>{}
                                                  : phase::ReadExposureStacks(right_dir, scheme);
    // Images of another size than the rig's camera: name the folder (the library cannot).
    auto require_size = [&](const std::vector<cv::Mat>& imgs, const CameraModel& cam,
                            const fs::path& dir) {
      if (!imgs.empty() && (imgs[0].cols != cam.width || imgs[0].rows != cam.height)) {
        throw Error(util::StrCat(dir.string(), ": images are ", imgs[0].cols, "x", imgs[0].rows,
                                 " but the camera of ", rig_name, " is ", cam.width, "x",
                                 cam.height));
      }
    };
    require_size(left, rig.left, left_dir);
    if (!camera_projector) require_size(right_exposures.front(), rig.right, right_dir);
    // In a scan folder the full scale follows the bit depth its manifest states.
    if (a->bit_depth == 0 && scan_root) {
      a->bit_depth = scan::ScanFolder::Open(*scan_root).manifest().bit_depth;
    }
    if (a->bit_depth > 0) a->options.decode.full_scale_dn = std::ldexp(1.0, a->bit_depth) - 1;
    a->options.compute_normals = !a->no_normals;
    a->options.remove_outliers = !a->keep_outliers;
    stereo::ViewReconstruction rec;
    if (camera_projector) {
      rec = stereo::MakeCameraProjectorReconstructor(
                stereo::CameraProjectorRig::FromLeftCamera(rig), schemes, a->options)
                .Reconstruct([&] {
                  stereo::ViewStacks stacks{left_stacks, {}};
                  stacks.more_left_exposures = more_left;
                  return stacks;
                }());
      text << rec.summary.decode_left.BriefReport() << " (camera"
           << (two_directions ? ", vertical" : "") << ")\n";
      if (two_directions)
        text << rec.summary.decode_right.BriefReport() << " (camera, horizontal)\n";
      text << rec.summary.matching.BriefReport() << "\n";
      WarnIfSchemeMismatch(rec.summary.decode_left, scheme.name, left_dirs[0].string());
      if (two_directions) {
        WarnIfSchemeMismatch(rec.summary.decode_right, schemes[1].name, left_dirs[1].string());
      }
    } else {
      rec = trinocular ? stereo::ViewReconstructor(
                             stereo::MakeTrinocularCorrespondence(rig, a->options.matching),
                             {scheme}, a->options)
                             .Reconstruct(left_exposures, right_exposures)
                       : stereo::ViewReconstructor(rig, scheme, a->options)
                             .Reconstruct(left_exposures, right_exposures);
      text << rec.summary.decode_left.BriefReport() << " (left)\n"
           << rec.summary.decode_right.BriefReport() << " (right)\n"
           << rec.summary.matching.BriefReport() << "\n";
      WarnIfSchemeMismatch(rec.summary.decode_left, scheme.name, left_dir.string());
      WarnIfSchemeMismatch(rec.summary.decode_right, scheme.name, right_dir.string());
    }
    if (a->options.remove_outliers) text << rec.summary.outliers.BriefReport() << "\n";
    if (a->options.compute_normals) text << rec.summary.normals.BriefReport() << "\n";
    text << rec.summary.BriefReport() << "\n";
    if (!rec.summary.ok()) {
      // Name the calibration too: a wrong or foreign rig is the usual cause of no points.
      throw Error(util::StrCat("reconstruct: ", view.string(), ": ",
                               stereo::ToString(rec.summary.status), ": ", rec.summary.message,
                               " (calibration ", rig_name, ")"));
    }
    // The cloud, the residual image and the markers are committed together or not at all.
    util::OutputTransaction outputs;
    outputs.Write(a->out, [&](const fs::path& tmp) {
      io::WritePly(tmp, rec.cloud,
                   a->ascii ? io::PlyFormat::kAscii : io::PlyFormat::kBinaryLittleEndian,
                   {camera_projector
                        ? "fringe reconstruct (camera-projector): camera frame, mm; quality = "
                          "fringe modulation (DN), intensity = texture, residual_px = round trip "
                          "into the projector (px)"
                        : "fringe reconstruct: left camera frame, mm; quality = fringe modulation "
                          "(DN), intensity = texture, residual_px = reprojection residual (px)"});
    });
    if (!a->residuals.empty()) {
      outputs.Write(a->residuals,
                    [&](const fs::path& tmp) { io::WriteImage(tmp, rec.reprojection_error_px); });
    }
    std::optional<registration::ViewMarkers> markers;
    // Stereo: markers triangulated from both cameras' textures; one camera: its ring centre's
    // ray against the measured surface.
    if (!a->no_markers) {
      markers = camera_projector ? registration::DetectViewMarkersOneCamera(
                                       rig.left, rec.texture_left, rec.cloud)
                                 : registration::DetectViewMarkers(rig, rec.texture_left,
                                                                   rec.texture_right, rec.cloud);
      outputs.Write(markers_path, [&](const fs::path& tmp) {
        registration::WriteViewMarkers(tmp, markers->markers);
      });
    }
    outputs.Commit();
    if (a->json) {
      nlohmann::json j = {{"view", view.string()},
                          {"mode", camera_projector ? "camera-projector"
                                   : trinocular     ? "trinocular"
                                                    : "stereo"},
                          {"out", a->out},
                          {"summary", stereo::ToJson(rec.summary)}};
      if (markers) {
        j["markers"] = {{"file", markers_path.string()},
                        {"count", markers->markers.size()},
                        {"report", markers->summary.BriefReport()}};
      }
      std::cout << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
      return;
    }
    text << "wrote " << a->out << " (" << rec.summary.points << " points)\n";
    if (markers) {
      text << markers->summary.BriefReport() << "\nwrote " << markers_path.string() << "\n";
    }
  });
}

FRINGE_REGISTER_COMMAND(60, AddReconstructCommand);

}  // namespace fringe::cli
