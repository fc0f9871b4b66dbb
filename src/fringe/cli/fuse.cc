// fringe fuse: registered view clouds -> one single-layer fused cloud (+ optional mesh).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "fringe/cli/cli.h"
#include "fringe/fusion/fuse.h"
#include "fringe/fusion/mesh.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/ply.h"
#include "fringe/pipeline/result_layout.h"
#include "fringe/registration/registration_io.h"
#include "fringe/scan/truth.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::cli {
namespace {

namespace fs = std::filesystem;

// world_from_sensor by view name from a poses.json (scan::ReadTruthPoses: the schema of the
// simulator's truth/poses.json and of `fringe register`'s DIR/poses.json).
std::map<std::string, Rigid3d> ReadPoses(const fs::path& path) {
  const std::map<std::string, Rigid3d> poses = scan::ReadTruthPoses(path).ByView();
  if (poses.empty()) throw Error(util::StrCat(path.string(), ": no views"));
  return poses;
}

}  // namespace

void AddFuseCommand(CLI::App& app) {
  struct Args {
    std::vector<std::string> inputs;
    std::string poses;
    std::string out;
    std::string mesh;
    bool json = false;
    bool ascii = false;
    fusion::FusionOptions fusion;
    fusion::MeshOptions meshing;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "fuse",
      "Fuse registered views into one single-layer cloud (adaptive-neighbourhood mean "
      "clustering) and optionally mesh it (screened Poisson)");
  sub->add_option("inputs", a->inputs,
                  "View clouds (organized PLY in their sensor frame, from fringe reconstruct) with "
                  "--poses, or one folder written by fringe register (DIR/poses.json + "
                  "DIR/registered/NAME.ply)")
      ->required();
  sub->add_option(
      "--poses", a->poses,
      "poses.json: world_from_sensor per view, the view named by its cloud's file stem");
  sub->add_option("--out", a->out, "Fused cloud (PLY, world frame)")->required();
  sub->add_option("--mesh", a->mesh, "Also write a mesh (.ply with normals, or .stl)");
  sub->add_flag("--watertight", a->meshing.watertight,
                "Keep the closed Poisson surface (default: trim what the data do not support)");
  sub->add_option("--max-triangles", a->meshing.max_triangles,
                  "Decimate the mesh to at most N triangles (quadric error; the deviation it adds "
                  "is reported)");
  sub->add_option("--poisson-depth", a->meshing.poisson_depth,
                  "Poisson octree depth (0: from the point spacing and the extent)")
      ->capture_default_str();
  sub->add_option("--mesh-resolution", a->meshing.resolution_mm,
                  "Wanted mesh resolution, mm: the automatic depth's finest cell is this, or 2 "
                  "point spacings if coarser (0: as fine as the points allow)")
      ->check(CLI::Range(0.0, 10000.0))
      ->capture_default_str();
  sub->add_option("--poisson-pieces", a->meshing.poisson_pieces,
                  "Poisson in two pieces side by side, joined on a grid plane: 0 automatic "
                  "(surfaces of 200,000 finest cells and more), 1 never, 2 always")
      ->check(CLI::Range(0, 2))
      ->capture_default_str();
  sub->add_option("--registration-rms", a->fusion.registration_rms_mm,
                  "Registration residual (mm): widens the overlap radius")
      ->capture_default_str();
  sub->add_flag("--json", a->json, "Print the summary as JSON");
  sub->add_flag("--ascii", a->ascii, "Write the fused cloud as ASCII PLY");
  sub->callback([a] {
    a->fusion.Check();
    a->meshing.Check();
    // The output rule before any work: no output is, contains or lies inside an input (the
    // clouds, a registration folder, the poses).
    {
      std::vector<fs::path> inputs(a->inputs.begin(), a->inputs.end());
      if (!a->poses.empty()) inputs.push_back(a->poses);
      util::CheckOutputFile(a->out, inputs);
      if (!a->mesh.empty()) {
        util::CheckOutputFile(a->mesh, inputs);
        util::CheckDistinctOutputs({a->out, a->mesh});
      }
    }
    std::vector<fusion::FusionView> views;
    std::vector<fs::path> read;
    if (a->inputs.size() == 1 && fs::is_directory(a->inputs[0])) {
      // A registration folder: the registered (world-frame) clouds go back to their sensor
      // frames by the inverse poses, so that no pose is applied twice and the viewing angles
      // are known.
      const fs::path dir(a->inputs[0]);
      const pipeline::ResultLayout layout{dir};
      const fs::path poses_path = a->poses.empty() ? layout.Poses() : fs::path(a->poses);
      util::RequireFile(poses_path, "poses file");
      for (const auto& [name, world_from_sensor] : ReadPoses(poses_path)) {
        const fs::path cloud = layout.RegisteredCloud(name);
        if (!fs::exists(cloud)) {
          throw Error(util::StrCat("fuse: ", poses_path.string(), " names view '", name, "' but ",
                                   cloud.string(), " does not exist"));
        }
        fusion::FusionView v{name, io::ReadOrganizedPly(cloud), world_from_sensor};
        registration::TransformGrid(world_from_sensor.Inverse(), &v.cloud);
        views.push_back(std::move(v));
        read.push_back(cloud);
      }
    } else {
      if (a->poses.empty()) {
        throw Error(
            "fuse: view clouds need --poses (poses.json), or give one folder written by "
            "fringe register");
      }
      const std::map<std::string, Rigid3d> poses = ReadPoses(a->poses);
      for (const auto& in : a->inputs) {
        const fs::path cloud(in);
        const std::string name = cloud.stem().string();
        const auto it = poses.find(name);
        if (it == poses.end()) {
          throw Error(util::StrCat("fuse: ", a->poses, " has no pose for view '", name, "' (",
                                   cloud.string(), ")"));
        }
        views.push_back({name, io::ReadOrganizedPly(cloud), it->second});
        read.push_back(cloud);
      }
    }
    // The clouds a registration folder names were read too (through links, they may lie
    // elsewhere).
    util::CheckOutputFile(a->out, read);
    if (!a->mesh.empty()) util::CheckOutputFile(a->mesh, read);

    const fusion::FusionResult fused = fusion::FuseViews(views, a->fusion);
    nlohmann::json summary = {{"fusion", fusion::ToJson(fused.summary)}};
    if (!a->json) std::cout << fused.summary.BriefReport() << "\n";
    if (!fused.summary.has_output()) {
      if (a->json) std::cout << summary.dump(2) << "\n";
      throw Error(util::StrCat("fuse: ", fusion::ToString(fused.summary.status), ": ",
                               fused.summary.message));
    }
    // Mesh first: a failed mesh leaves no output at all.
    fusion::MeshResult mesh;
    if (!a->mesh.empty()) {
      mesh = fusion::MeshPoisson(fused.fused, a->meshing);
      summary["mesh"] = fusion::ToJson(mesh.summary);
      if (!a->json) std::cout << mesh.summary.BriefReport() << "\n";
      if (!mesh.summary.ok()) {
        if (a->json) std::cout << summary.dump(2) << "\n";
        throw Error(util::StrCat("fuse: mesh: ", fusion::ToString(mesh.summary.status), ": ",
                                 mesh.summary.message));
      }
    }
    // Both outputs or neither: a failed mesh write leaves no fused cloud either.
    util::OutputTransaction outputs;
    outputs.Write(a->out, [&](const fs::path& tmp) {
      io::WritePly(
          tmp, fused.fused, a->ascii ? io::PlyFormat::kAscii : io::PlyFormat::kBinaryLittleEndian,
          {"fringe fuse: world frame (the first view's sensor frame after fringe register), "
           "mm; intensity = texture (also as grey colour), quality = weighted modulation"});
    });
    if (!a->mesh.empty()) {
      outputs.Write(a->mesh, [&](const fs::path& tmp) { fusion::WriteMeshFile(tmp, mesh); });
    }
    outputs.Commit();
    if (a->json) {
      std::cout << summary.dump(2) << "\n";
    } else {
      std::cout << "wrote " << a->out << " (" << fused.fused.size() << " points)"
                << (a->mesh.empty() ? "" : ", " + a->mesh) << "\n";
    }
  });
}

FRINGE_REGISTER_COMMAND(80, AddFuseCommand);

}  // namespace fringe::cli
