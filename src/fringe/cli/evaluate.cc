// fringe evaluate: VDI/VDE 2634-2 figures of a measured artefact, or deviation from a mesh.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "fringe/cli/cli.h"
#include "fringe/eval/deviation.h"
#include "fringe/eval/vdi2634.h"
#include "fringe/geometry/align.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/json.h"
#include "fringe/io/mesh_io.h"
#include "fringe/io/ply.h"
#include "fringe/registration/align_to_mesh.h"
#include "fringe/registration/registration_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::cli {
namespace {

namespace fs = std::filesystem;

fs::path TruthMesh(const fs::path& p) {
  if (!fs::is_directory(p)) return p;
  for (const char* name : {"truth/scene.ply", "scene.ply", "truth.ply", "mesh.ply"}) {
    if (fs::exists(p / name)) return p / name;
  }
  throw Error(util::StrCat("evaluate: ", p.string(),
                           " has no truth mesh (truth/scene.ply, scene.ply, truth.ply, mesh.ply)"));
}

// --align-pairs: {"pairs": [{"cloud": [x, y, z], "mesh": [x, y, z]}, ...]}, at least three
// picked point pairs (mm); their rigid fit is the start of the alignment.
Rigid3d ReadAlignPairs(const fs::path& path) {
  const nlohmann::json j = io::ReadJson(path);
  const std::string ctx = path.string();
  io::RequireObject(j, ctx);
  if (!j.contains("pairs") || !j["pairs"].is_array() || j["pairs"].size() > 10000) {
    throw Error(ctx + ".pairs: expected an array of at most 10000 point pairs");
  }
  std::vector<Eigen::Vector3d> in_cloud, in_mesh;
  for (size_t k = 0; k < j["pairs"].size(); ++k) {
    const std::string c = util::StrCat(ctx, ".pairs[", k, "]");
    const std::vector<double> p = io::GetNumbers(j["pairs"][k], "cloud", 3, c);
    const std::vector<double> q = io::GetNumbers(j["pairs"][k], "mesh", 3, c);
    in_cloud.emplace_back(p[0], p[1], p[2]);
    in_mesh.emplace_back(q[0], q[1], q[2]);
  }
  const RigidAlignment fit = AlignRigid(in_cloud, in_mesh);
  if (!fit.ok()) {
    throw Error(util::StrCat(ctx, ": the point pairs do not fix a pose (", fit.message,
                             "); give three or more pairs not on one line"));
  }
  return fit.b_from_a;  // mesh_from_cloud
}

}  // namespace

void AddEvaluateCommand(CLI::App& app) {
  struct Args {
    std::string cloud;
    std::string artefact;
    double diameter_mm = 0;
    double distance_mm = 0;
    std::string truth;
    std::string pose;
    std::string map;
    double range_mm = 0.1;
    bool json = false;
    bool align = false;
    std::string align_pairs;
    registration::MeshAlignOptions align_options;
    eval::VdiOptions vdi;
    eval::DeviationOptions deviation;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "evaluate",
      "VDI/VDE 2634-2 figures of a measured sphere, ball bar or plane (PF, PS, SD, F with the "
      "0.3 % allowance), or the deviation of a cloud from a reference mesh");
  sub->add_option("cloud", a->cloud, "Measured point cloud (PLY)")->required();
  sub->add_option("--artefact", a->artefact, "sphere | ballbar | plane")
      ->check(CLI::IsMember({"sphere", "ballbar", "plane"}));
  sub->add_option("--diameter", a->diameter_mm,
                  "Calibrated sphere diameter, mm; without it the sphere is searched with a free "
                  "radius and PF, RMS and the fitted diameter are given, PS is not")
      ->check(CLI::PositiveNumber);
  sub->add_option("--distance", a->distance_mm, "Calibrated ball-bar centre distance, mm");
  sub->add_option("--truth", a->truth,
                  "Reference mesh (PLY) or a folder holding truth/scene.ply: deviation mode");
  sub->add_option("--pose", a->pose,
                  "JSON rigid transform mesh_from_cloud ({\"rotation\", \"translation_mm\"}); "
                  "default identity (cloud and mesh in the same frame)");
  sub->add_flag("--align", a->align,
                "Best-fit the cloud to the mesh first (point-to-plane ICP onto the mesh with a "
                "shrinking threshold, starting from --pose, --align-pairs or identity); reports "
                "the transform and its residual");
  sub->add_option("--align-pairs", a->align_pairs,
                  "JSON {\"pairs\": [{\"cloud\": [x,y,z], \"mesh\": [x,y,z]}, ...]}: three or "
                  "more picked point pairs giving the start of --align when it is far");
  sub->add_option("--align-threshold", a->align_options.initial_threshold_mm,
                  "First correspondence threshold of --align, mm (cover the start's error)")
      ->capture_default_str();
  sub->add_option("--map", a->map, "Deviation colour-map image to write (PNG)");
  sub->add_option("--range", a->range_mm, "Colour-map range +-mm")->capture_default_str();
  sub->add_option("--max-distance", a->deviation.max_distance_mm,
                  "Points farther from the mesh are unmatched, mm")
      ->capture_default_str();
  sub->add_option("--band", a->vdi.inlier_band_mm,
                  "Half width of the band of points belonging to the artefact, mm")
      ->capture_default_str();
  sub->add_option("--discard", a->vdi.discard_fraction,
                  "Fraction of points that may be left out (<= 0.003)")
      ->capture_default_str();
  sub->add_option("--seed", a->vdi.seed, "RANSAC seed")->capture_default_str();
  sub->add_flag("--json", a->json, "Print one JSON object");
  sub->callback([a] {
    if (a->artefact.empty() == a->truth.empty()) {
      throw CLI::ValidationError("evaluate", "give exactly one of --artefact and --truth");
    }
    if (a->artefact == "ballbar" && !(a->distance_mm > 0)) {
      throw CLI::ValidationError("evaluate", "--artefact ballbar needs --distance (mm)");
    }
    if ((a->align || !a->align_pairs.empty()) && a->truth.empty()) {
      throw CLI::ValidationError("evaluate", "--align and --align-pairs need --truth");
    }
    if (!a->align_pairs.empty()) a->align = true;
    if (!a->align_pairs.empty() && !a->pose.empty()) {
      throw CLI::ValidationError("evaluate", "give at most one of --pose and --align-pairs");
    }
    a->align_options.min_threshold_mm =
        std::min(a->align_options.min_threshold_mm, a->align_options.initial_threshold_mm);
    a->align_options.Check();
    if (!a->map.empty()) {
      util::CheckOutputFile(a->map, {a->cloud, a->truth, a->pose, a->align_pairs});
      if (a->truth.empty()) throw CLI::ValidationError("evaluate", "--map needs --truth");
    }
    const io::PlyData ply = io::ReadPly(a->cloud);
    const PointCloud& cloud = ply.cloud;
    nlohmann::json j = {{"cloud", a->cloud}, {"points", cloud.size()}};
    std::string text;
    bool ok = true;  // a stage that produces no figure exits 1 after printing why
    if (!a->truth.empty()) {
      const fs::path mesh_path = TruthMesh(a->truth);
      TriangleMesh mesh = io::ReadMesh(mesh_path);  // throws naming the file when empty
      for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        if (!mesh.vertices[i].allFinite()) {
          throw Error(util::StrCat(mesh_path.string(), ": vertex ", i,
                                   " is not finite (NaN or infinite coordinates)"));
        }
      }
      Rigid3d mesh_from_cloud;
      if (!a->pose.empty()) mesh_from_cloud = io::RigidFromJson(io::ReadJson(a->pose), a->pose);
      if (a->align) {
        if (!a->align_pairs.empty()) mesh_from_cloud = ReadAlignPairs(a->align_pairs);
        const MeshIndex reference(mesh);  // mesh frame
        const registration::MeshAlignResult r =
            registration::AlignToMesh(cloud, reference, mesh_from_cloud, a->align_options);
        j["align"] = registration::ToJson(r);
        if (!a->json) std::cout << r.BriefReport() << "\n";
        if (r.status == registration::IcpStatus::kNoOverlap) {
          throw Error(
              util::StrCat(a->cloud, ": cannot align to ", mesh_path.string(), ": ", r.message));
        }
        mesh_from_cloud = r.mesh_from_cloud;
      }
      // Move the mesh into the cloud's frame (keeps the cloud's grid for the colour map).
      if (!a->pose.empty() || a->align) mesh.Transform(mesh_from_cloud.Inverse());
      const MeshIndex distance(std::move(mesh));
      std::vector<double> d;
      const eval::DeviationStats s = eval::DeviationFromMesh(cloud, distance, a->deviation, &d);
      j["truth"] = mesh_path.string();
      j["deviation"] = eval::ToJson(s);
      text = s.BriefReport();
      ok = s.points > 0;
      if (ok && !a->map.empty()) {
        cv::Mat img;
        if (ply.header.grid_width > 0 && ply.grid_index.size() == cloud.size()) {
          std::vector<double> grid(
              static_cast<size_t>(ply.header.grid_width) * ply.header.grid_height, std::nan(""));
          for (size_t i = 0; i < cloud.size(); ++i) grid.at(ply.grid_index[i]) = d[i];
          img = eval::DeviationColorMap(ply.header.grid_width, ply.header.grid_height, grid,
                                        a->range_mm);
        } else {
          img = eval::DeviationColorMapTopView(cloud, d, a->range_mm);
        }
        io::WriteImage(a->map, img);
        j["map"] = a->map;
      }
    } else if (a->artefact == "sphere") {
      const eval::SphereResult r = eval::EvaluateSphere(cloud, a->diameter_mm, a->vdi);
      j["sphere"] = eval::ToJson(r);
      text = r.BriefReport();
      ok = r.ok();
    } else if (a->artefact == "ballbar") {
      const eval::BallBarResult r =
          eval::EvaluateBallBar(cloud, a->diameter_mm, a->distance_mm, a->vdi);
      j["ballbar"] = eval::ToJson(r);
      text = r.BriefReport();
      ok = r.ok();
    } else {
      const eval::PlaneResult r = eval::EvaluatePlane(cloud, a->vdi);
      j["plane"] = eval::ToJson(r);
      text = r.BriefReport();
      ok = r.ok();
    }
    if (a->json) {
      std::cout << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
    } else {
      std::cout << text << "\n";
    }
    if (!ok) throw Error(util::StrCat(a->cloud, ": evaluation failed (see above)"));
  });
}

FRINGE_REGISTER_COMMAND(100, AddEvaluateCommand);

}  // namespace fringe::cli
