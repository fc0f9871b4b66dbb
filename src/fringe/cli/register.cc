// fringe register: view clouds (sensor frames) -> poses in one world frame, the marker map and
// the clouds moved into the world (registration/register_views.h).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "fringe/cli/cli.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/ply.h"
#include "fringe/pipeline/result_layout.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/register_views.h"
#include "fringe/registration/registration_io.h"
#include "fringe/scan/truth.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::cli {

namespace fs = std::filesystem;

void AddRegisterCommand(CLI::App& app) {
  struct Args {
    std::vector<std::string> clouds;
    std::string out;
    std::string initial;
    std::string units = "mm";
    bool no_markers = false;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "register",
      "place view clouds in one world frame (markers by distance invariance, marker-free "
      "FPFH + RANSAC fallback, global marker adjustment, multi-level multi-view ICP)");
  sub->add_option("clouds", a->clouds,
                  "View PLYs in their sensor frames (OUT.markers.json beside "
                  "each is used when present)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--out", a->out,
                  "Output folder: poses.json, markers.json, registered/NAME.ply (organized when "
                  "the input is, for fringe fuse DIR), summary.json (created; must not be an "
                  "input's folder)")
      ->required();
  sub->add_option("--initial", a->initial, "Initial poses (poses.json schema), by view name")
      ->check(CLI::ExistingFile);
  sub->add_option("--units", a->units, "Units of the input clouds")
      ->check(CLI::IsMember({"mm", "m"}));
  sub->add_flag("--no-markers", a->no_markers, "Ignore markers: marker-free path for every view");
  sub->add_flag("--json", a->json, "Print the summary as JSON");
  sub->callback([a] {
    const double scale = a->units == "m" ? 1000.0 : 1.0;
    const fs::path out_dir = fs::absolute(a->out).lexically_normal();
    std::vector<registration::RegistrationView> views;
    std::set<std::string> names;
    std::vector<fs::path> inputs;
    for (const std::string& c : a->clouds) inputs.push_back(fs::absolute(c).lexically_normal());
    // The output rule before any work: the folder is replaced at the end, so it must not hold a
    // cloud, its markers file or the initial poses (an earlier scan's output folder does).
    util::OutputFolderOptions output;
    output.inputs = inputs;
    for (const fs::path& p : inputs) {
      output.inputs.push_back(registration::MarkersPathForCloud(p));
    }
    if (!a->initial.empty()) output.inputs.push_back(a->initial);
    util::CheckOutputFolder(out_dir, output);
    for (size_t i = 0; i < inputs.size(); ++i) {
      std::string note;
      registration::RegistrationView v =
          registration::ReadRegistrationView(inputs[i], scale, !a->no_markers, &note);
      if (!names.insert(v.name).second) {
        throw Error(util::StrCat("register: two inputs are named '", v.name,
                                 "' (view names are file stems and must be unique)"));
      }
      if (!note.empty() && !a->json) std::cout << a->clouds[i] << ": " << note << "\n";
      views.push_back(std::move(v));
    }
    if (!a->initial.empty()) {
      const scan::TruthPoses poses = scan::ReadTruthPoses(a->initial);
      size_t found = 0;
      for (auto& v : views) {
        if (const scan::ViewPose* p = poses.Find(v.name)) {
          Rigid3d t = p->world_from_sensor;
          if (scale != 1) t = Rigid3d(t.rotation(), t.translation() * scale);
          v.initial_world_from_sensor = t;
          ++found;
        }
      }
      // Initial poses for some views only are a valid start; for none, the file belongs to
      // other clouds (view names are the clouds' file stems).
      if (found == 0) {
        throw Error(util::StrCat("register: ", a->initial, " has a pose for none of the ",
                                 views.size(), " clouds (views are named by file stem, e.g. '",
                                 views.front().name, "' for ", a->clouds.front(), ")"));
      }
    }
    registration::RegistrationOptions options;
    options.use_markers = !a->no_markers;
    const registration::RegistrationResult r = registration::RegisterViews(views, options);
    // No result, no output folder: fail before anything is written.
    if (r.summary.status == registration::RegistrationStatus::kFailed) {
      throw Error(util::StrCat("register: ", r.summary.message));
    }

    std::vector<std::string> placed_names;
    std::vector<Rigid3d> placed_poses;
    for (const auto& v : r.views) {
      if (!v.placed()) continue;
      placed_names.push_back(v.name);
      placed_poses.push_back(v.world_from_sensor);
    }
    util::WriteFolderAtomically(out_dir, output, [&](const fs::path& tmp) {
      const pipeline::ResultLayout layout{tmp};
      registration::WritePoses(layout.Poses(), placed_names, placed_poses);
      registration::WriteMarkerMap(layout.MarkerMap(), r, views);
      io::WriteJson(layout.Summary(), registration::ToJson(r));
      fs::create_directories(layout.RegisteredDir());
      for (size_t i = 0; i < views.size(); ++i) {
        if (!r.views[i].placed()) continue;
        registration::WriteRegisteredView(
            layout.RegisteredCloud(views[i].name), inputs[i], scale, views[i],
            r.views[i].world_from_sensor,
            "fringe register: world frame (first view's sensor frame), mm");
      }
    });
    if (a->json) {
      std::cout << registration::ToJson(r).dump(2) << "\n";
    } else {
      for (const auto& v : r.views) {
        std::cout << v.name << ": " << registration::ToString(v.path);
        if (v.matched_markers > 0) std::cout << ", " << v.matched_markers << " markers";
        if (!v.message.empty()) std::cout << " (" << v.message << ")";
        std::cout << "\n";
      }
      std::cout << r.summary.adjustment.BriefReport() << "\n"
                << r.summary.icp.BriefReport() << "\n"
                << r.summary.BriefReport() << "\nwrote " << a->out << "\n";
    }
    // Some views not placed: the others are written, and the exit code says it was partial
    // (as `fringe scan --keep-going`), so that scripts notice.
    if (r.summary.status == registration::RegistrationStatus::kPartial) throw ExitWithCode(3);
  });
}

FRINGE_REGISTER_COMMAND(70, AddRegisterCommand);

}  // namespace fringe::cli
