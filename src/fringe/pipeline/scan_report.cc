// The scan's report: its sections (summary, fused cloud and mesh, registration, calibration,
// views) and the per-view pictures, from what the scanner's stages hand over (scan_model.h).
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "fringe/calib/diagnostics.h"
#include "fringe/pipeline/report.h"
#include "fringe/pipeline/scan.h"
#include "fringe/pipeline/scan_model.h"
#include "fringe/util/error.h"
#include "fringe/util/format.h"

namespace fringe::pipeline {
namespace internal {

namespace fs = std::filesystem;
using util::Fixed;
using util::StrCat;

namespace {

cv::Mat GridChannel(const OrganizedPointCloud& cloud, const std::vector<float>* attribute,
                    int axis) {
  cv::Mat m(cloud.height, cloud.width, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (int r = 0; r < cloud.height; ++r) {
    for (int c = 0; c < cloud.width; ++c) {
      const size_t i = cloud.index(c, r);
      if (!cloud.valid[i]) continue;
      m.at<float>(r, c) =
          attribute ? (*attribute)[i] : static_cast<float>(cloud.cloud.points[i][axis]);
    }
  }
  return m;
}

ReportTable ViewTable(const std::vector<ScanViewSummary>& views, bool stereo) {
  ReportTable t;
  t.caption = "Views";
  // One camera + projector: the second decoded column is the second fringe direction's (0
  // with one scheme).
  t.header = {"view",
              "status",
              "points",
              "markers",
              "measured px",
              stereo ? "decoded left" : "decoded",
              stereo ? "decoded right" : "decoded 2nd direction",
              "read s",
              "decode s",
              "reconstruct s",
              "epipolar RMS px",
              "projector bias px",
              "drift"};
  for (const ScanViewSummary& v : views) {
    if (!v.ok) {
      t.rows.push_back({v.name, "FAILED in " + v.failed_stage + ": " + v.message, "", "", "", "",
                        "", Fixed(v.read_s, 3), Fixed(v.decode_s, 3), Fixed(v.reconstruct_s, 3), "",
                        "", ""});
      continue;
    }
    const ViewDrift& d = v.drift;
    t.rows.push_back({v.name, "ok", std::to_string(v.points), std::to_string(v.markers),
                      Fixed(100 * v.valid_fraction, 1) + " %",
                      Fixed(100 * v.decode_valid_left, 1) + " %",
                      Fixed(100 * v.decode_valid_right, 1) + " %", Fixed(v.read_s, 3),
                      Fixed(v.decode_s, 3), Fixed(v.reconstruct_s, 3),
                      std::isfinite(d.epipolar_rms_px) ? Fixed(d.epipolar_rms_px, 3) : "-",
                      std::isfinite(d.projector_bias_px) ? Fixed(d.projector_bias_px, 3) : "-",
                      !d.checked ? "not checked"
                      : d.drift  ? "DRIFT"
                                 : "no"});
  }
  return t;
}

// Top view of the marker map over the fused cloud, in the display frame.
cv::Mat MarkerMapPicture(const Model& m, int size_px) {
  cv::Mat img(size_px, size_px, CV_8UC3, cv::Scalar(255, 255, 255));
  std::vector<Eigen::Vector3d> markers, points;
  for (const registration::MapMarker& k : m.registration.map) {
    markers.push_back(m.display_from_world * k.centre_in_world);
  }
  for (size_t i : Stride(m.fused.fused.size(), 200000)) {
    points.push_back(m.display_from_world * m.fused.fused.points[i]);
  }
  Eigen::Vector2d lo(1e30, 1e30), hi(-1e30, -1e30);
  for (const auto* set : {&markers, &points}) {
    for (const Eigen::Vector3d& p : *set) {
      lo = lo.cwiseMin(p.head<2>());
      hi = hi.cwiseMax(p.head<2>());
    }
  }
  if (!(hi.x() > lo.x()) || !(hi.y() > lo.y())) return img;
  const double scale = 0.9 * size_px / std::max(hi.x() - lo.x(), hi.y() - lo.y());
  const Eigen::Vector2d centre = 0.5 * (lo + hi);
  auto pixel = [&](const Eigen::Vector3d& p) {
    // Image rows grow downward: display y up on the picture.
    return cv::Point(static_cast<int>(std::lround(0.5 * size_px + scale * (p.x() - centre.x()))),
                     static_cast<int>(std::lround(0.5 * size_px - scale * (p.y() - centre.y()))));
  };
  for (const Eigen::Vector3d& p : points) {
    const cv::Point q = pixel(p);
    if (q.x >= 0 && q.y >= 0 && q.x < size_px && q.y < size_px) {
      img.at<cv::Vec3b>(q) = cv::Vec3b(190, 190, 190);
    }
  }
  for (size_t k = 0; k < markers.size(); ++k) {
    const registration::MapMarker& mk = m.registration.map[k];
    const cv::Point q = pixel(markers[k]);
    const int r = std::max(3, static_cast<int>(std::lround(scale * mk.outer_radius_mm)));
    // Colour by the number of views that saw the marker: red 1, orange 2, green 3 or more.
    const cv::Scalar colour = mk.sightings.size() >= 3   ? cv::Scalar(0, 150, 0)
                              : mk.sightings.size() == 2 ? cv::Scalar(0, 140, 255)
                                                         : cv::Scalar(0, 0, 220);
    cv::circle(img, q, r, colour, 2, cv::LINE_AA);
    cv::putText(img, StrCat(mk.id, " (", mk.sightings.size(), ")"), q + cv::Point(r + 2, -r),
                cv::FONT_HERSHEY_SIMPLEX, 0.35, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  return img;
}

// The drift verdict for the report: the warning first, with the views and the evidence.
std::string DriftParagraph(const ScanSummary& s) {
  if (s.drift_views_checked == 0) {
    return "Calibration drift: not checked (no view had redundant evidence: markers seen by both "
           "cameras, a calibrated projector, or fringes in two directions).";
  }
  std::string evidence;
  for (const std::string& e : s.drift_evidence) evidence += (evidence.empty() ? "" : ", ") + e;
  std::string p = s.calibration_drift
                      ? "WARNING: calibration drift. The rig no longer describes the sensor: "
                      : "Calibration drift: none found. ";
  p += StrCat(s.drift_views_checked, " of ", s.views_ok, " views checked from ", evidence,
              "; epipolar RMS over the views ",
              std::isfinite(s.epipolar_rms_px) ? Fixed(s.epipolar_rms_px, 3) + " px" : "-",
              " (thresholds: systematic epipolar residual ",
              s.drift_options.max_epipolar_systematic_px, " px and ",
              s.drift_options.min_epipolar_significance, " standard errors, projector bias ",
              s.drift_options.max_projector_bias_px, " px, its plane across the image ",
              s.drift_options.max_projector_systematic_px, " px).");
  for (const ScanViewSummary& v : s.views) {
    if (v.ok && v.drift.drift) p += StrCat(" View ", v.name, ": ", v.drift.message, ".");
  }
  if (s.calibration_drift) {
    p += " Recalibrate, or refine the rig from this scan (fringe refine).";
  }
  return p;
}

ReportSection RegistrationSection(const ScanSummary& s, const Model& m) {
  ReportSection sec;
  sec.title = "Registration";
  sec.paragraphs.push_back(m.registration.summary.BriefReport());
  sec.paragraphs.push_back(m.registration.summary.adjustment.BriefReport());
  ReportTable t;
  t.caption = "Views (world = the first view's sensor frame)";
  t.header = {
      "view",    "path",        "markers",      "matched", "marker fit RMS mm", "adjusted RMS mm",
      "overlap", "rot err deg", "trans err mm", "message"};
  for (size_t k = 0; k < m.inputs.size(); ++k) {
    const registration::ViewRegistration& r = m.registration.views[k];
    const ScanViewSummary& vs = s.views[static_cast<size_t>(m.view_of[k])];
    t.rows.push_back({r.name, registration::ToString(r.path), std::to_string(r.markers),
                      std::to_string(r.matched_markers), Fixed(r.marker_rms_mm, 4),
                      Fixed(r.adjusted_rms_mm, 4), Fixed(100 * r.overlap_fraction, 1) + " %",
                      std::isfinite(vs.rot_err_deg) ? Fixed(vs.rot_err_deg, 4) : "-",
                      std::isfinite(vs.trans_err_mm) ? Fixed(vs.trans_err_mm, 4) : "-", r.message});
  }
  sec.tables.push_back(t);
  ReportTable levels;
  levels.caption = "Multi-view ICP, per level";
  levels.header = {"level",        "points/view", "iterations", "threshold mm",
                   "RMS start mm", "RMS end mm",  "pairs",      "converged"};
  for (const registration::IcpLevelReport& l : m.registration.summary.icp.levels) {
    levels.rows.push_back({std::to_string(l.level), std::to_string(l.points_per_view),
                           std::to_string(l.iterations),
                           Fixed(l.threshold_start_mm, 3) + " -> " + Fixed(l.threshold_end_mm, 3),
                           Fixed(l.rms_start_mm, 4), Fixed(l.rms_end_mm, 4),
                           std::to_string(l.correspondences), l.converged ? "yes" : "no"});
  }
  sec.tables.push_back(levels);
  // Per level: the residual distribution at its last iteration (the registration summary's
  // subsample), range 1.5 x its 99th percentile so that the shape fills the picture.
  for (const registration::IcpLevelReport& l : m.registration.summary.icp.levels) {
    if (l.residuals_mm.empty()) continue;
    const std::vector<double> r(l.residuals_mm.begin(), l.residuals_mm.end());
    const double lim_l = std::min(l.threshold_start_mm, std::max(0.01, 1.5 * l.residual_p99_mm));
    sec.images.push_back(
        {StrCat("ICP level ", l.level, ": signed point-to-plane residuals at its last iteration (",
                r.size(), " of ", l.correspondences, " correspondences; |r| median ",
                Fixed(l.residual_p50_mm, 4), ", 90 % ", Fixed(l.residual_p90_mm, 4), ", 99 % ",
                Fixed(l.residual_p99_mm, 4), " mm; red: the level's final threshold)"),
         HistogramImage(r, -lim_l, lim_l, 60, "point-to-plane residual, mm",
                        {l.threshold_end_mm, -l.threshold_end_mm})});
  }
  // Histogram range: five times the larger RMS, so that the shape (not the search radius) fills
  // the picture; residuals beyond it are counted in the end bins.
  const double lim = std::min(
      m.residual_threshold_mm,
      std::max(0.02, 5 * std::max(Rms(m.residuals_adjusted_mm), Rms(m.residuals_final_mm))));
  if (!m.residuals_final_mm.empty() || !m.residuals_adjusted_mm.empty()) {
    sec.paragraphs.push_back(StrCat(
        "Point-to-plane residuals between overlapping views (", Fixed(m.residual_threshold_mm, 3),
        " mm search radius = ICP's first threshold; the per-level figures above are ICP's "
        "own, over its kept correspondences): RMS ",
        Fixed(Rms(m.residuals_adjusted_mm), 4), " mm at the marker-adjusted poses, ",
        Fixed(Rms(m.residuals_final_mm), 4), " mm after ICP."));
    sec.images.push_back(
        {"residuals at the marker-adjusted poses (before ICP), mm",
         HistogramImage(m.residuals_adjusted_mm, -lim, lim, 60, "point-to-plane residual, mm")});
    std::vector<double> marks;
    for (const auto& l : m.registration.summary.icp.levels) {
      marks.push_back(l.threshold_end_mm);
      marks.push_back(-l.threshold_end_mm);
    }
    sec.images.push_back({"residuals after multi-level ICP, mm (red: the levels' final thresholds)",
                          HistogramImage(m.residuals_final_mm, -lim, lim, 60,
                                         "point-to-plane residual, mm", marks)});
  }
  if (!m.marker_residuals_mm.empty()) {
    const double hi = std::max(
        0.05, 1.2 * *std::max_element(m.marker_residuals_mm.begin(), m.marker_residuals_mm.end()));
    sec.images.push_back(
        {"marker sightings: distance to the marker map after registration, mm",
         HistogramImage(m.marker_residuals_mm, 0, hi, 30, "marker centre to map, mm")});
  }
  if (!m.registration.map.empty()) {
    sec.images.push_back(
        {StrCat("marker map (", m.registration.map.size(),
                " markers, top view over the fused cloud; label: id (views that saw it); green 3+, "
                "orange 2, red 1 view)"),
         MarkerMapPicture(m, 560)});
  }
  return sec;
}

// The 3D view's input: the model as the scan wrote it (world frame) and its sensors.
ScanSceneInput SceneInput(const Model& m, const CameraModel& camera) {
  ScanSceneInput in;
  in.mesh = &m.mesh.mesh;
  in.mesh_deviation_mm = &m.mesh_deviation_mm;
  in.deviation_range = m.mesh_deviation_range;
  in.fused = &m.fused.fused;
  in.fused_support = &m.fused.support;
  in.fused_view = &m.fused.view;
  for (size_t k = 0; k < m.inputs.size(); ++k) {
    const registration::ViewRegistration& r = m.registration.views[k];
    const int f = m.fusion_of[k];
    if (f >= 0) {
      in.fused_view_names.resize(std::max(in.fused_view_names.size(), size_t(f) + 1));
      in.fused_view_names[size_t(f)] = r.name;
    }
    if (r.placed()) in.sensors.push_back({r.name, r.world_from_sensor, camera});
  }
  for (const registration::MapMarker& mk : m.registration.map) {
    in.markers.push_back(
        {mk.id, mk.centre_in_world, mk.outer_radius_mm, static_cast<int>(mk.sightings.size())});
  }
  in.display_from_world = m.display_from_world;
  return in;
}

ReportSection ModelSection(const ScanSummary& s, const Model& m, const CameraModel& camera) {
  ReportSection sec;
  sec.title = "Fused cloud and mesh";
  sec.paragraphs.push_back(m.fused.summary.BriefReport());
  sec.paragraphs.push_back(m.mesh.summary.BriefReport());
  sec.scene = ScanScene(SceneInput(m, camera));
  sec.paragraphs.push_back(
      "The 3D view below shows the mesh (decimated when large, for the page to stay light; "
      "mesh.ply has all of it), a sample of the fused points (fused.ply), the markers and each "
      "view's sensor at its registered pose; select a view in the tables to highlight it.");
  TriangleMesh display = m.mesh.mesh;
  display.Transform(m.display_from_world);
  const std::vector<std::pair<std::string, Eigen::Vector3d>> directions = {
      {"from above", Eigen::Vector3d(0, 0, -1)},
      {"from the front, 45 degrees down", Eigen::Vector3d(0, 1, -1)},
      {"from the side, 45 degrees down", Eigen::Vector3d(-1, 0, -1)},
      {"from the back, 30 degrees down", Eigen::Vector3d(0, -1.7, -1)}};
  const MeshRenderer renderer(display);  // one Embree scene for every picture
  for (const auto& [label, d] : directions) {
    sec.images.push_back({"mesh " + label, renderer.Render(d.normalized())});
  }
  if (s.has_truth && !m.mesh_deviation_mm.empty()) {
    ReportTable t;
    t.caption = "Against the truth (simulated scan; fused cloud and mesh placed by the gauge)";
    t.header = {"figure", "mm"};
    t.rows = {{"single-view RMS in the overlaps (as fused: estimated poses)",
               Fixed(s.single_view_rms_mm, 4)},
              {"single-view RMS in the overlaps (true poses: the sensor alone)",
               Fixed(s.single_view_sensor_rms_mm, 4)},
              {"single-view RMS, all points (true poses)", Fixed(s.single_view_all_rms_mm, 4)},
              {"fused RMS (all points)", Fixed(s.fused_rms_mm, 4)},
              {"fused RMS (points merged from 2+ views)", Fixed(s.fused_overlap_rms_mm, 4)},
              {"mesh vertices RMS", Fixed(s.mesh_rms_mm, 4)},
              {"truth (where measured) to the mesh, RMS", Fixed(s.mesh_truth_rms_mm, 4)},
              {"max pose rotation error, deg", Fixed(s.pose_rot_err_deg, 4)},
              {"max pose centroid displacement", Fixed(s.pose_trans_err_mm, 4)}};
    sec.tables.push_back(t);
    const io::DeviationRange& range = m.mesh_deviation_range;
    for (const auto& [label, d] : {directions[0], directions[1]}) {
      sec.images.push_back(
          {"mesh deviation from the truth " + label + " (signed, mm; grey: farther than 2 mm)",
           renderer.RenderColoured(m.mesh_deviation_mm, range.lo(), range.hi(),
                                   range.Legend("signed deviation from truth, mm"), d.normalized(),
                                   560, 420)});
    }
  }
  return sec;
}

}  // namespace

// The left texture image with the measured markers circled (their outer ring) and numbered.
cv::Mat TextureWithMarkers(const cv::Mat& texture_left,
                           const std::vector<registration::ViewMarker>& markers,
                           const StereoRig& rig, int max_width_px) {
  cv::Mat grey;
  texture_left.convertTo(grey, CV_8U);
  cv::Mat colour;
  cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
  const double scale = std::min(1.0, double(max_width_px) / colour.cols);
  if (scale < 1) cv::resize(colour, colour, cv::Size(), scale, scale, cv::INTER_AREA);
  for (const registration::ViewMarker& m : markers) {
    const cv::Point2d c(m.left_px.x() * scale, m.left_px.y() * scale);
    const double r_px = std::max(
        4.0, 1.5 * rig.left.fx * m.outer_radius_mm / std::max(1.0, m.centre_in_sensor.z()) * scale);
    cv::circle(colour, c, static_cast<int>(std::lround(r_px)), cv::Scalar(0, 0, 255), 2,
               cv::LINE_AA);
    cv::putText(colour, std::to_string(m.id), c + cv::Point2d(r_px, -r_px),
                cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 255, 255), 1, cv::LINE_AA);
  }
  return colour;
}

// The absolute phase of the left camera for the report: the reconstruction's own phase map
// (ViewReconstruction::phase_left), shrunk to the picture's width as the other maps are (the
// mean of the decoded pixels of each picture pixel, grey where fewer than half were decoded).
ReportImage PhasePicture(const std::string& name, const cv::Mat& phase_left, int max_width_px) {
  const auto range = DisplayRange(phase_left, 0.0);
  return {StrCat("view ", name, ": absolute phase of the left camera (projector column)"),
          ColourMapWithBar(phase_left, range[0], range[1], "absolute phase, projector px",
                           max_width_px)};
}

std::vector<ReportImage> ViewPictures(const std::string& name, const OrganizedPointCloud& cloud) {
  std::vector<ReportImage> out;
  const cv::Mat depth = GridChannel(cloud, nullptr, 2);
  const auto dr = DisplayRange(depth);
  out.push_back({StrCat("view ", name, ": depth (z in the sensor frame), mm"),
                 ColourMapWithBar(depth, dr[0], dr[1], "depth z, mm", 480)});
  if (cloud.cloud.has_quality()) {
    const cv::Mat modulation = GridChannel(cloud, &cloud.cloud.quality, 0);
    const auto mr = DisplayRange(modulation);
    out.push_back(
        {StrCat("view ", name, ": fringe modulation at measured points, DN"),
         ColourMapWithBar(modulation, std::max(0.0, mr[0]), mr[1], "modulation, DN", 480)});
  }
  return out;
}

// z opposite the views' mean viewing direction (the sensors look down at the part).
Rigid3d DisplayFromViews(const std::vector<Rigid3d>& world_from_sensor) {
  Eigen::Vector3d look = Eigen::Vector3d::Zero();
  for (const Rigid3d& t : world_from_sensor) look += t.RotateDirection(Eigen::Vector3d::UnitZ());
  if (look.norm() < 1e-6) return Rigid3d();
  const Eigen::Vector3d z = -look.normalized();
  const Eigen::Vector3d helper =
      std::abs(z.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d x = (helper - helper.dot(z) * z).normalized();
  Eigen::Matrix3d world_from_display;
  world_from_display << x, z.cross(x), z;
  return Rigid3d(Eigen::Matrix3d(world_from_display.transpose()), Eigen::Vector3d::Zero());
}

Report BuildReport(const fs::path& project, const ScanSummary& s, const Calibration& cal,
                   const std::vector<ViewResult>& views, const Model& model) {
  Report r;
  r.title = "fringe scan of " + project.filename().string();
  {
    ReportSection sec;
    sec.title = "Summary";
    sec.paragraphs.push_back(s.BriefReport());
    ReportTable t;
    t.caption = "Timings (read, decode and reconstruct are summed over views running in parallel)";
    t.header = {"stage", "seconds"};
    for (const auto& [name, value] : std::vector<std::pair<std::string, double>>{
             {"calibrate", s.calibrate_s},
             {"read images", s.read_s},
             {"decode fringes", s.decode_s},
             {"reconstruct", s.reconstruct_s},
             {"markers", s.markers_s},
             {"views (wall)", s.views_s},
             {"register", s.register_s},
             {"fuse", s.fuse_s},
             {"mesh", s.mesh_s},
             {"total (wall, without calibration; the report's own time is in summary.json)",
              s.total_s},
             {"truth comparison (not in the total)", s.evaluate_s}}) {
      t.rows.push_back({name, Fixed(value, 3)});
    }
    sec.tables.push_back(t);
    ReportTable m;
    m.caption = "Result";
    m.header = {"figure", "value"};
    m.rows = {
        {"views measured", StrCat(s.views_ok, " of ", s.views.size())},
        {"points", std::to_string(s.points)},
        {"registration", s.registration_status},
        {"marker adjustment RMS", Fixed(s.marker_adjusted_rms_mm, 4) + " mm"},
        {"ICP RMS (last level)", Fixed(s.icp_rms_mm, 4) + " mm"},
        {"fused points", std::to_string(s.fused_points)},
        {"mesh", StrCat(s.mesh_vertices, " vertices, ", s.mesh_triangles, " triangles")},
        {"peak memory", Fixed(s.peak_mem_gib, 2) + " GiB (limit " + Fixed(s.memory_limit_gib, 2) +
                            " GiB; fusion in " + std::to_string(s.fusion_tiles) + " tile(s))"}};
    if (s.has_truth) {
      m.rows.push_back({"pose error (max over views)", Fixed(s.pose_rot_err_deg, 4) + " deg, " +
                                                           Fixed(s.pose_trans_err_mm, 4) + " mm"});
      m.rows.push_back(
          {"single-view RMS vs truth (overlaps)", Fixed(s.single_view_rms_mm, 4) + " mm"});
      m.rows.push_back({"fused RMS vs truth", Fixed(s.fused_rms_mm, 4) + " mm"});
      m.rows.push_back({"mesh RMS vs truth", Fixed(s.mesh_rms_mm, 4) + " mm"});
    }
    sec.tables.push_back(m);
    for (const ScanViewSummary& v : s.views) {
      if (!v.ok) {
        sec.paragraphs.push_back(StrCat("View ", v.name, " was left out: it failed in stage '",
                                        v.failed_stage, "': ", v.message));
      }
    }
    r.sections.push_back(std::move(sec));
  }
  // The model and its registration first: what people look at; the per-view pictures last.
  r.sections.push_back(ModelSection(s, model, cal.rig.left));
  r.sections.push_back(RegistrationSection(s, model));
  {
    ReportSection sec;
    sec.title = "Calibration";
    sec.paragraphs.push_back("Rig from " + cal.source + ".");
    if (!s.calibration_report.empty()) {
      sec.paragraphs.push_back(StrCat(
          "Calibrated from this scan folder's board images: the calibration's own report, with its "
          "residuals per pose, coverage and predicted depth uncertainty, is ",
          s.calibration_report, " in this folder."));
    }
    for (const std::string& w : s.calibration_warnings) {
      sec.paragraphs.push_back("Calibration warning: " + w);
    }
    sec.paragraphs.push_back(DriftParagraph(s));
    ReportTable t;
    // The second device: the right camera, or in a camera + projector scan the projector.
    const CameraModel& second = s.stereo ? cal.rig.right : *cal.rig.projector;
    t.header = {"figure", s.stereo ? "left" : "camera", s.stereo ? "right" : "projector"};
    t.rows.push_back({"focal length fx, px", Fixed(cal.rig.left.fx, 2), Fixed(second.fx, 2)});
    t.rows.push_back({"image size, px", StrCat(cal.rig.left.width, " x ", cal.rig.left.height),
                      StrCat(second.width, " x ", second.height)});
    if (cal.folder) {
      t.rows.push_back({"reprojection RMS, px",
                        Fixed(cal.folder->pair.left.summary.final_rms_px, 4),
                        Fixed(cal.folder->pair.right.summary.final_rms_px, 4)});
    } else if (cal.projector_folder) {
      t.rows.push_back({"reprojection RMS, px", Fixed(s.calibration_rms_left_px, 4),
                        Fixed(s.calibration_rms_projector_px, 4)});
    }
    sec.tables.push_back(t);
    sec.paragraphs.push_back(
        s.stereo ? "Baseline " + Fixed(cal.rig.BaselineMm(), 3) + " mm."
                 : "Camera + projector: camera to projector distance " +
                       Fixed(cal.rig.projector_from_left.translation().norm(), 3) + " mm.");
    // Stereo without a calibrated projector: the projector's columns fitted to this scan.
    if (s.projector_columns.is_object()) {
      sec.paragraphs.push_back(
          s.projector_columns_used
              ? StrCat("No calibrated projector: its columns were fitted to this scan's points (",
                       s.projector_columns.at("message").get<std::string>(), "); ",
                       s.projector_column_rejected,
                       " points off their projector column (false matches) were dropped.")
              : StrCat("No calibrated projector, and its columns could not be fitted to this "
                       "scan (",
                       s.projector_columns.at("message").get<std::string>(),
                       "): matches were not checked against the projector."));
    }
    if (cal.projector_folder) {
      sec.images.push_back({"camera: residual vectors (magnified) and board coverage",
                            calib::ResidualImage(cal.projector_folder->LeftCamera())});
    }
    if (cal.folder) {
      sec.images.push_back({"left camera: residual vectors (magnified) and board coverage",
                            calib::ResidualImage(cal.folder->pair.left)});
      sec.images.push_back({"right camera: residual vectors (magnified) and board coverage",
                            calib::ResidualImage(cal.folder->pair.right)});
    }
    r.sections.push_back(std::move(sec));
  }
  {
    ReportSection sec;
    sec.title = "Views";
    sec.tables.push_back(ViewTable(s.views, s.stereo));
    for (const ViewResult& v : views) {
      for (const ReportImage& p : v.pictures) sec.images.push_back(p);
    }
    r.sections.push_back(std::move(sec));
  }
  return r;
}

}  // namespace internal
}  // namespace fringe::pipeline
