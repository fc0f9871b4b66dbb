#include "fringe/registration/registration_io.h"

#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>

#include <algorithm>
#include <cmath>

#include "fringe/geometry/normals.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/json.h"
#include "fringe/io/ply.h"
#include "fringe/scan/truth.h"
#include "fringe/util/error.h"

namespace fringe::registration {

using nlohmann::json;
using util::StrCat;

namespace {
json Vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }
json Vec(const Eigen::Vector2d& v) { return json::array({v.x(), v.y()}); }
// Signed residuals of a level over [-threshold_start, threshold_start] in kHistogramBins bins
// (the residuals lie within the level's thresholds by construction).
constexpr int kHistogramBins = 40;
json ResidualHistogram(const IcpLevelReport& l) {
  const double lim = l.threshold_start_mm;
  std::vector<int64_t> counts(kHistogramBins, 0);
  for (float r : l.residuals_mm) {
    const int b = static_cast<int>(std::floor((r + lim) / (2 * lim) * kHistogramBins));
    ++counts[std::clamp(b, 0, kHistogramBins - 1)];
  }
  return {{"min_mm", -lim},
          {"max_mm", lim},
          {"samples", l.residuals_mm.size()},
          {"correspondences", l.correspondences},
          {"searched_pairs", l.searched_pairs},
          {"counts", counts}};
}
}  // namespace

RegistrationView ReadRegistrationView(const std::filesystem::path& ply, double scale_to_mm,
                                      bool read_markers, std::string* normals_note) {
  RegistrationView v;
  v.name = ply.stem().string();
  const io::PlyHeader header = io::ReadPlyHeader(ply);
  std::string note;
  if (header.grid_width > 0 && header.grid_height > 0) {
    const OrganizedPointCloud grid = ReadViewGrid(ply, scale_to_mm, &note);
    v.cloud = grid.Compact();
    v.grid = IndexViewGrid(grid);
  } else {
    v.cloud = io::ReadPly(ply).cloud;
    for (auto& p : v.cloud.points) p *= scale_to_mm;
    if (!v.cloud.has_normals() && v.cloud.size() >= 10) {
      open3d::geometry::PointCloud o;
      o.points_ = v.cloud.points;
      o.EstimateNormals(open3d::geometry::KDTreeSearchParamKNN(20));
      o.OrientNormalsTowardsCameraLocation(Eigen::Vector3d::Zero());
      v.cloud.normals = o.normals_;
      note = "normals estimated from 20 nearest neighbours";
    }
  }
  if (read_markers) {
    const std::filesystem::path mp = MarkersPathForCloud(ply);
    if (std::filesystem::exists(mp)) {
      v.markers = ReadViewMarkers(mp);
      if (scale_to_mm != 1) {
        for (ViewMarker& m : v.markers) {
          m.centre_in_sensor *= scale_to_mm;
          m.outer_radius_mm *= scale_to_mm;
          m.sigma_mm *= scale_to_mm;
          m.covariance_mm2 *= scale_to_mm * scale_to_mm;
        }
      }
    }
  }
  if (normals_note) *normals_note = note;
  return v;
}

OrganizedPointCloud ReadViewGrid(const std::filesystem::path& ply, double scale_to_mm,
                                 std::string* normals_note) {
  OrganizedPointCloud grid = io::ReadOrganizedPly(ply);
  for (size_t i = 0; i < grid.valid.size(); ++i) {
    if (grid.valid[i]) grid.cloud.points[i] *= scale_to_mm;
  }
  std::string note;
  if (!grid.cloud.has_normals()) {
    EstimateGridNormals(&grid);
    note = "normals estimated on the grid";
  }
  if (normals_note) *normals_note = note;
  return grid;
}

void TransformGrid(const Rigid3d& b_from_a, OrganizedPointCloud* grid) {
  PointCloud& c = grid->cloud;
  for (size_t i = 0; i < grid->valid.size(); ++i) {
    if (!grid->valid[i]) continue;
    c.points[i] = b_from_a * c.points[i];
    if (c.has_normals()) c.normals[i] = b_from_a.RotateDirection(c.normals[i]);
  }
}

void WriteRegisteredView(const std::filesystem::path& out, const std::filesystem::path& ply,
                         double scale_to_mm, const RegistrationView& view,
                         const Rigid3d& world_from_sensor, const std::string& comment) {
  const io::PlyHeader header = io::ReadPlyHeader(ply);
  if (header.grid_width > 0 && header.grid_height > 0) {
    // Read again rather than kept from ReadRegistrationView: one grid in memory at a time.
    OrganizedPointCloud grid = ReadViewGrid(ply, scale_to_mm, nullptr);
    TransformGrid(world_from_sensor, &grid);
    io::WritePly(out, grid, io::PlyFormat::kBinaryLittleEndian, {comment});
    return;
  }
  PointCloud moved = view.cloud;
  for (auto& p : moved.points) p = world_from_sensor * p;
  for (auto& n : moved.normals) n = world_from_sensor.RotateDirection(n);
  io::WritePly(out, moved, io::PlyFormat::kBinaryLittleEndian, {comment});
}

void WritePoses(const std::filesystem::path& path, const std::vector<std::string>& names,
                const std::vector<Rigid3d>& world_from_sensor) {
  scan::TruthPoses poses;
  for (size_t i = 0; i < names.size(); ++i) poses.views.push_back({names[i], world_from_sensor[i]});
  json j = scan::PosesToJson(poses);
  j.erase("turntable");  // a registration's world is the first view's frame, not a turntable
  j["format"] = "fringe-poses";
  j["version"] = 1;
  io::WriteJson(path, j);
}

void WriteMarkerMap(const std::filesystem::path& path, const RegistrationResult& result,
                    const std::vector<RegistrationView>& views) {
  json markers = json::array();
  std::vector<json> obs(result.views.size(), json::array());
  for (const MapMarker& m : result.map) {
    const ViewMarker& first =
        views[m.sightings.front().view].markers[m.sightings.front().view_marker];
    const double ratio = 0.6;  // the markers' inner / outer radius (MarkerDetectionOptions)
    markers.push_back({{"id", m.id},
                       {"centre_in_world", Vec(m.centre_in_world)},
                       {"normal_in_world", Vec(m.normal_in_world)},
                       {"inner_radius_mm", ratio * first.outer_radius_mm},
                       {"outer_radius_mm", m.outer_radius_mm},
                       {"sightings", m.sightings.size()}});
    for (const auto& s : m.sightings) {
      const ViewMarker& vm = views[s.view].markers[s.view_marker];
      obs[s.view].push_back({{"id", m.id},
                             {"centre_in_sensor", Vec(vm.centre_in_sensor)},
                             {"left_px", Vec(vm.left_px)},
                             {"right_px", Vec(vm.right_px)},
                             {"visible_left", true},
                             {"visible_right", true}});
    }
  }
  json vlist = json::array();
  for (size_t v = 0; v < result.views.size(); ++v) {
    vlist.push_back({{"view", result.views[v].name}, {"observations", obs[v]}});
  }
  io::WriteJson(path, {{"format", "fringe-markers"},
                       {"version", 1},
                       {"frame", "world, mm"},
                       {"markers", markers},
                       {"views", vlist}});
}

json ToJson(const IcpLevelReport& l) {
  return {{"level", l.level},
          {"points_per_view", l.points_per_view},
          {"threshold_start_mm", l.threshold_start_mm},
          {"threshold_end_mm", l.threshold_end_mm},
          {"iterations", l.iterations},
          {"converged", l.converged},
          {"rms_start_mm", l.rms_start_mm},
          {"rms_end_mm", l.rms_end_mm},
          {"correspondences", l.correspondences},
          {"degenerate_directions", l.degenerate_directions},
          {"projective_pairs", l.projective_pairs},
          {"last_step_rotation_deg", l.last_step_rotation_deg},
          {"last_step_translation_mm", l.last_step_translation_mm},
          {"last_step_sigmas", l.last_step_sigmas},
          {"residual_p50_mm", l.residual_p50_mm},
          {"residual_p90_mm", l.residual_p90_mm},
          {"residual_p99_mm", l.residual_p99_mm},
          {"residual_histogram", ResidualHistogram(l)}};
}

json ToJson(const MeshAlignResult& r) {
  json levels = json::array();
  for (const IcpLevelReport& l : r.levels) levels.push_back(ToJson(l));
  return {{"status", ToString(r.status)},
          {"message", r.message},
          {"mesh_from_cloud", io::RigidToJson(r.mesh_from_cloud)},
          {"rms_mm", r.rms_mm},
          {"points", r.correspondences},
          {"seconds", r.seconds},
          {"levels", levels}};
}

json ToJson(const RegistrationResult& r) {
  json views = json::array();
  for (const ViewRegistration& v : r.views) {
    views.push_back({{"view", v.name},
                     {"path", ToString(v.path)},
                     {"message", v.message},
                     {"markers", v.markers},
                     {"matched_markers", v.matched_markers},
                     {"marker_rms_mm", v.marker_rms_mm},
                     {"adjusted_rms_mm", v.adjusted_rms_mm},
                     {"overlap_fraction", v.overlap_fraction},
                     {"surface_noise_mm", v.surface_noise_mm}});
  }
  json levels = json::array();
  for (const IcpLevelReport& l : r.summary.icp.levels) levels.push_back(ToJson(l));
  const AdjustmentSummary& a = r.summary.adjustment;
  return {{"status", ToString(r.summary.status)},
          {"message", r.summary.message},
          {"placed", r.summary.placed},
          {"unplaced", r.summary.unplaced},
          {"bad_input", r.summary.bad_input},
          {"seconds", r.summary.seconds},
          {"views", views},
          {"marker_map", r.map.size()},
          {"adjustment",
           {{"status", ToString(a.status)},
            {"rms_initial_mm", a.rms_initial_mm},
            {"rms_final_mm", a.rms_final_mm},
            {"observations", a.observations},
            {"message", a.message}}},
          {"icp",
           {{"status", ToString(r.summary.icp.status)},
            {"message", r.summary.icp.message},
            {"touching_pairs", r.summary.icp.touching_pairs},
            {"associated_pairs", r.summary.icp.associated_pairs},
            {"levels", levels}}}};
}

}  // namespace fringe::registration
