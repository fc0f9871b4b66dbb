// Files of multi-view registration (docs/formats.md): view clouds in, poses.json, the marker map
// markers.json and the summary out.
//
// poses.json: {"format": "fringe-poses", "version": 1, "frame": "world_from_sensor (sensor =
// left camera), mm", "views": [{"view": NAME, "world_from_sensor": {"rotation": [[3x3]],
// "translation_mm": [3]}}]}: the schema of a simulated scan's truth/poses.json plus
// format/version. markers.json: the schema of truth/markers.json (docs/scan-folder.md).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/registration/align_to_mesh.h"
#include "fringe/registration/register_views.h"

namespace fringe::registration {

// A view from a PLY cloud (organized or not) and, when present, the markers file beside it
// (MarkersPathForCloud). Clouds without normals get them: grid normals for organized clouds,
// otherwise Open3D's k-nearest-neighbour PCA oriented toward the sensor (the frame's origin);
// `normals_note` says which. Points are multiplied by `scale_to_mm` (1000 for metres). Throws
// fringe::Error naming the file for unreadable input.
RegistrationView ReadRegistrationView(const std::filesystem::path& ply, double scale_to_mm,
                                      bool read_markers, std::string* normals_note);

// The grid of an organized view PLY, scaled to mm, with grid normals estimated when it has none
// (as ReadRegistrationView does). Throws fringe::Error naming the file when it has no grid.
OrganizedPointCloud ReadViewGrid(const std::filesystem::path& ply, double scale_to_mm,
                                 std::string* normals_note);

// Moves the valid points (and their normals) of `grid` by b_from_a; invalid slots stay as they
// are, so the grid structure survives (fringe fuse reads registered clouds as grids).
void TransformGrid(const Rigid3d& b_from_a, OrganizedPointCloud* grid);

// DIR/registered/NAME.ply for one placed view: the input's grid moved into the world when the
// input `ply` is organized (fringe fuse REGDIR needs grids), else the view's compact cloud
// moved. Written atomically.
void WriteRegisteredView(const std::filesystem::path& out, const std::filesystem::path& ply,
                         double scale_to_mm, const RegistrationView& view,
                         const Rigid3d& world_from_sensor, const std::string& comment);

// poses.json: scan::PosesToJson's schema plus format/version (read back with
// scan::ReadTruthPoses, the one poses reader).
void WritePoses(const std::filesystem::path& path, const std::vector<std::string>& names,
                const std::vector<Rigid3d>& world_from_sensor);

// The marker map in truth/markers.json's schema; "views" lists each view's sightings.
void WriteMarkerMap(const std::filesystem::path& path, const RegistrationResult& result,
                    const std::vector<RegistrationView>& views);

// The summary as JSON (per view: path, message, markers, matched, residuals, overlap; the
// adjustment and ICP levels).
nlohmann::json ToJson(const RegistrationResult& result);
// AlignToMesh's result (`fringe evaluate --align`): status, message, mesh_from_cloud, rms_mm,
// points, seconds, levels.
nlohmann::json ToJson(const MeshAlignResult& result);
// One ICP level (the levels of both summaries above).
nlohmann::json ToJson(const IcpLevelReport& level);

}  // namespace fringe::registration
