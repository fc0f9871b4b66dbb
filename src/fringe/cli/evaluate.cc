// fringe evaluate: VDI/VDE 2634-2 figures of a measured artefact, or deviation from a mesh.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "fringe/cli/cli.h"
#include "fringe/eval/deviation.h"
#include "fringe/eval/vdi2634.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/mesh_io.h"
#include "fringe/io/ply.h"
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
  sub->add_option("--diameter", a->diameter_mm, "Calibrated sphere diameter, mm");
  sub->add_option("--distance", a->distance_mm, "Calibrated ball-bar centre distance, mm");
  sub->add_option("--truth", a->truth,
                  "Reference mesh (PLY) or a folder holding truth/scene.ply: deviation mode");
  sub->add_option("--pose", a->pose,
                  "JSON rigid transform mesh_from_cloud ({\"rotation\", \"translation_mm\"}); "
                  "default identity (cloud and mesh in the same frame)");
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
    if (!a->map.empty()) {
      util::CheckOutputFile(a->map, {a->cloud, a->truth, a->pose});
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
      // Move the mesh into the cloud's frame (keeps the cloud's grid for the colour map).
      if (!a->pose.empty()) {
        mesh.Transform(io::RigidFromJson(io::ReadJson(a->pose), a->pose).Inverse());
      }
      const eval::MeshDistance distance(std::move(mesh));
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
