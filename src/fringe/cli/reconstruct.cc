// fringe reconstruct: one view (left/ and right/ fringe image stacks, or one camera's stack with a
// calibrated projector) -> organized point cloud. The flags of pipeline::ReconstructViewFolder.
#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "fringe/cli/calibration_flags.h"
#include "fringe/cli/cli.h"
#include "fringe/cli/scheme_flags.h"
#include "fringe/pipeline/reconstruct.h"

namespace fringe::cli {

void AddReconstructCommand(CLI::App& app) {
  struct Args {
    std::string view;
    std::string out;
    std::string residuals;
    std::string mode = "auto";
    bool no_normals = false;
    bool keep_outliers = false;
    bool no_markers = false;
    bool json = false;
    pipeline::ReconstructFolderOptions options;  // the calibration flags fill its base
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
  AddCalibrationFlags(sub, &a->options, "VIEW/rig.json or VIEW/../rig.json");
  sub->add_option("--scheme", a->options.scheme,
                  "Scheme manifest or preset name; default: in a scan folder the scheme its "
                  "scan.json names, else VIEW/manifest.json, VIEW/left/manifest.json or "
                  "VIEW/../manifest.json");
  AddSchemeFlags(sub, &a->options.parameters);
  sub->add_option("--out", a->out,
                  "Output PLY, a .ply name (organized: keeps the left camera grid)")
      ->required();
  sub->add_option("--residuals", a->residuals,
                  "Also write the per-pixel reprojection residual (32-bit float TIFF, pixels)");
  sub->add_option("--noise-sigma", a->options.reconstruction.decode.noise_sigma_dn,
                  "Camera noise in DN (sets the decoder's modulation threshold); 0 estimates it "
                  "from the images' least-squares residual")
      ->capture_default_str();
  sub->add_option("--min-modulation", a->options.reconstruction.decode.min_modulation_dn,
                  "Fringe modulation threshold in DN (0: from the noise and the scheme)")
      ->capture_default_str();
  sub->add_option("--bit-depth", a->options.bit_depth,
                  "Significant bits of the images (e.g. 12 for 12-bit data in 16-bit PNGs): the "
                  "full scale for saturation, exposure and texture; default from the scan "
                  "folder's scan.json, else the image container's (8 or 16)")
      ->check(CLI::Range(1, 16));
  sub->add_option("--gamma", a->options.reconstruction.decode.projector_gamma,
                  "Measured projector gamma (0: unknown). The decoder corrects only what the "
                  "scheme's gamma_precompensation did not: gamma / gamma_precompensation")
      ->capture_default_str();
  sub->add_option("--max-reprojection",
                  a->options.reconstruction.matching.max_reprojection_error_px,
                  "Drop points with a larger reprojection residual (pixels)")
      ->capture_default_str();
  sub->add_option("--max-projector-error",
                  a->options.reconstruction.matching.max_projector_error_px,
                  "Projector consistency tolerance in projector pixels (0: off; needs a "
                  "calibrated projector in the rig)")
      ->capture_default_str();
  sub->add_flag("--no-normals", a->no_normals, "Do not estimate normals");
  sub->add_flag("--keep-outliers", a->keep_outliers, "Do not remove flying pixels / small patches");
  sub->add_flag("--ascii", a->options.ascii_ply, "Write ASCII PLY");
  sub->add_flag("--json", a->json,
                "Print every stage's summary as one JSON object instead of the text report");
  sub->add_flag("--no-markers", a->no_markers,
                "Do not detect sticky markers (default: OUT.markers.json beside the cloud)");
  sub->callback([a] {
    pipeline::ReconstructFolderOptions& o = a->options;
    o.mode = pipeline::ReconstructModeFromString(a->mode);
    o.reconstruction.compute_normals = !a->no_normals;
    o.reconstruction.remove_outliers = !a->keep_outliers;
    o.detect_markers = !a->no_markers;
    o.residuals = a->residuals;
    const pipeline::ViewFolderReconstruction r =
        pipeline::ReconstructViewFolder(a->view, a->out, o);
    if (a->json) {
      // stdout is one JSON object: the text report is not printed.
      std::cout << pipeline::ToJson(r).dump(2, ' ', false, nlohmann::json::error_handler_t::replace)
                << "\n";
      return;
    }
    for (const std::string& line : r.report) std::cout << line << "\n";
    std::cout << "wrote " << a->out << " (" << r.reconstruction.summary.points << " points)\n";
    if (r.markers) {
      std::cout << r.markers->summary.BriefReport() << "\nwrote " << r.markers_file.string()
                << "\n";
    }
  });
}

FRINGE_REGISTER_COMMAND(60, AddReconstructCommand);

}  // namespace fringe::cli
