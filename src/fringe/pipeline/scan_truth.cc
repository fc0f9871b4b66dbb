// The scan's comparison with its folder's truth: pose errors after the gauge, single-view and
// fused deviations, the mesh both ways, the views' deviation pictures.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "fringe/eval/deviation.h"
#include "fringe/geometry/align.h"
#include "fringe/geometry/mesh_index.h"
#include "fringe/pipeline/scan.h"
#include "fringe/pipeline/scan_model.h"
#include "fringe/util/error.h"

namespace fringe::pipeline {
namespace internal {
namespace {

// The signed deviation from the truth mesh of an organized view's points placed by
// world_from_sensor, sampled on the grid every `step` pixels in both directions (the view's
// picture: point sampling keeps each value a real point's, no averaging across edges).
// `compact` lists the valid slots of the grid (`valid`, grid_size) in grid order.
cv::Mat ViewDeviationMap(const PointCloud& compact, const std::vector<uint8_t>& valid,
                         cv::Size grid_size, const Rigid3d& world_from_sensor,
                         const MeshIndex& distance, int max_width_px) {
  const int step = std::max(1, (grid_size.width + max_width_px - 1) / max_width_px);
  const int w = (grid_size.width + step - 1) / step, h = (grid_size.height + step - 1) / step;
  cv::Mat out(h, w, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  // Compact index of every valid grid slot.
  std::vector<int64_t> compact_of(valid.size(), -1);
  int64_t n = 0;
  for (size_t g = 0; g < valid.size(); ++g) {
    if (valid[g]) compact_of[g] = n++;
  }
  if (n != static_cast<int64_t>(compact.size())) return out;  // not this cloud's grid
  PointCloud sample;
  std::vector<cv::Point> where;
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      const size_t g = static_cast<size_t>(r * step) * static_cast<size_t>(grid_size.width) +
                       static_cast<size_t>(c * step);
      if (compact_of[g] < 0) continue;
      sample.points.push_back(world_from_sensor *
                              compact.points[static_cast<size_t>(compact_of[g])]);
      where.emplace_back(c, r);
    }
  }
  std::vector<double> d;
  eval::DeviationFromMesh(sample, distance, {}, &d);
  for (size_t i = 0; i < where.size() && i < d.size(); ++i) {
    out.at<float>(where[i]) = static_cast<float>(d[i]);
  }
  return out;
}

}  // namespace

// Every k-th index so that at most max_count of n remain (deterministic, spread over the grid).
std::vector<size_t> Stride(size_t n, size_t max_count) {
  const size_t step = std::max<size_t>(1, (n + max_count - 1) / std::max<size_t>(1, max_count));
  std::vector<size_t> out;
  for (size_t i = 0; i < n; i += step) out.push_back(i);
  return out;
}

double Rms(const std::vector<double>& v) {
  double sum = 0;
  int64_t n = 0;
  for (double x : v) {
    if (!std::isfinite(x)) continue;
    sum += x * x;
    ++n;
  }
  return n ? std::sqrt(sum / static_cast<double>(n)) : std::numeric_limits<double>::quiet_NaN();
}

// The comparison with the scan folder's truth (ScanSummary's truth figures).
void EvaluateAgainstTruth(const scan::ScanFolder& folder, Model* m, ScanSummary* s) {
  const scan::TruthPoses truth = folder.ReadTruthPoses();
  const size_t n = m->inputs.size();
  std::vector<Rigid3d> true_pose(n), est(n);
  std::vector<bool> use(n, false);
  std::vector<Eigen::Vector3d> a, b;  // gauge pairs: estimated world, true world
  for (size_t k = 0; k < n; ++k) {
    const registration::ViewRegistration& r = m->registration.views[k];
    const scan::ViewPose* p = truth.Find(r.name);
    if (!r.placed() || !p) continue;
    use[k] = true;
    true_pose[k] = p->world_from_sensor;
    est[k] = r.world_from_sensor;
    for (size_t i : Stride(m->inputs[k].cloud.size(), 2000)) {
      const Eigen::Vector3d& q = m->inputs[k].cloud.points[i];
      a.push_back(est[k] * q);
      b.push_back(true_pose[k] * q);
    }
  }
  const RigidAlignment gauge = AlignRigid(a, b);
  if (!gauge.ok()) throw Error("scan: truth comparison: no gauge: " + gauge.message);
  const Rigid3d& true_from_est = gauge.b_from_a;
  m->display_from_world = true_from_est;  // the truth's world has z up
  const MeshIndex distance(folder.ReadTruthMesh());
  s->pose_rot_err_deg = s->pose_trans_err_mm = 0;
  std::vector<double> single_all, single_overlap, single_overlap_placed;
  for (size_t k = 0; k < n; ++k) {
    if (!use[k]) continue;
    ScanViewSummary& vs = s->views[static_cast<size_t>(m->view_of[k])];
    const PointCloud& cloud = m->inputs[k].cloud;
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& q : cloud.points) c += q;
    c /= static_cast<double>(std::max<size_t>(1, cloud.size()));
    const Rigid3d placed = true_from_est * est[k];
    vs.rot_err_deg = (true_pose[k].rotation().inverse() * placed.rotation())
                         .angularDistance(Eigen::Quaterniond::Identity()) *
                     180 / M_PI;
    vs.trans_err_mm = (placed * c - true_pose[k] * c).norm();
    s->pose_rot_err_deg = std::max(s->pose_rot_err_deg, vs.rot_err_deg);
    s->pose_trans_err_mm = std::max(s->pose_trans_err_mm, vs.trans_err_mm);
    // The sensor alone: the view's points by their true pose (sampled, grid order), and which
    // of them fusion found in an overlap (the grid slots of the fusion view); the same points
    // as fusion got them, by the estimated pose mapped by G (as bench_fusion measures the
    // single views: by the poses it fuses with).
    PointCloud sample, sample_placed;
    std::vector<size_t> ids = Stride(cloud.size(), 100000);
    for (size_t i : ids) {
      sample.points.push_back(true_pose[k] * cloud.points[i]);
      sample_placed.points.push_back(placed * cloud.points[i]);
    }
    std::vector<double> d, d_placed;
    eval::DeviationFromMesh(sample, distance, {}, &d);
    eval::DeviationFromMesh(sample_placed, distance, {}, &d_placed);
    vs.truth_rms_mm = Rms(d);
    single_all.insert(single_all.end(), d.begin(), d.end());
    const int f = m->fusion_of[k];
    if (f >= 0 && !m->fused.overlap[static_cast<size_t>(f)].empty()) {
      // overlap is per grid slot; the compact cloud lists the valid slots in grid order.
      const std::vector<uint8_t>& overlap = m->fused.overlap[static_cast<size_t>(f)];
      const std::vector<uint8_t>& valid = m->grid_valid[k];
      std::vector<uint8_t> in_overlap;
      in_overlap.reserve(cloud.size());
      for (size_t g = 0; g < overlap.size() && g < valid.size(); ++g) {
        if (valid[g]) in_overlap.push_back(overlap[g]);
      }
      for (size_t j = 0; j < ids.size(); ++j) {
        if (ids[j] >= in_overlap.size() || !in_overlap[ids[j]]) continue;
        single_overlap.push_back(d[j]);
        single_overlap_placed.push_back(d_placed[j]);
      }
    }
  }
  s->single_view_all_rms_mm = Rms(single_all);
  s->single_view_rms_mm = Rms(single_overlap_placed);
  s->single_view_sensor_rms_mm = Rms(single_overlap);
  m->view_deviation_mm.assign(n, cv::Mat());
  for (size_t k = 0; k < n; ++k) {
    if (!use[k]) continue;
    m->view_deviation_mm[k] =
        ViewDeviationMap(m->inputs[k].cloud, m->grid_valid[k], m->grid_size[k], true_pose[k],
                         distance, kPictureWidthPx);
  }
  // Fused cloud and mesh, moved into the truth's world by the gauge.
  PointCloud fused_sample;
  {
    std::vector<size_t> ids = Stride(m->fused.fused.size(), 800000);
    for (size_t i : ids) fused_sample.points.push_back(true_from_est * m->fused.fused.points[i]);
    std::vector<double> d;
    eval::DeviationFromMesh(fused_sample, distance, {}, &d);
    s->fused_rms_mm = Rms(d);
    std::vector<double> merged;
    for (size_t j = 0; j < ids.size(); ++j) {
      if (m->fused.support[ids[j]] >= 2) merged.push_back(d[j]);
    }
    s->fused_overlap_rms_mm = Rms(merged);
  }
  {
    TriangleMesh mesh = m->mesh.mesh;
    mesh.Transform(true_from_est);
    std::vector<Eigen::Vector3d> measured;
    for (size_t i : Stride(fused_sample.size(), 200000)) {
      measured.push_back(fused_sample.points[i]);
    }
    MeshTruthFigures f = CompareMeshWithTruth(mesh, measured, distance);
    s->mesh_rms_mm = f.vertices_rms_mm;
    s->mesh_truth_rms_mm = f.truth_rms_mm;
    m->mesh_deviation_mm = std::move(f.vertex_deviation_mm);
  }
  s->truth_from_world = true_from_est;
}

// After a stage: without keep_going (or when no view is left) any failed view fails the scan,
// the error naming every failed view, its stage and why, and the views that worked; with
// keep_going the scan goes on without them and is partial.
// Views reconstructed at once within the memory limit: views_in_flight, lowered to what fits
// beside the memory in use; a limit below one view is an error naming the scan and the sizes.
}  // namespace internal

MeshTruthFigures CompareMeshWithTruth(const TriangleMesh& mesh_in_truth,
                                      const std::vector<Eigen::Vector3d>& measured_in_truth,
                                      const MeshIndex& truth) {
  MeshTruthFigures f;
  PointCloud vertices;
  vertices.points = mesh_in_truth.vertices;
  f.vertices_rms_mm = eval::DeviationFromMesh(vertices, truth, {}, &f.vertex_deviation_mm).rms_mm;
  if (mesh_in_truth.triangles.empty()) return f;
  const double max_mm = eval::DeviationOptions().max_distance_mm;
  std::vector<Eigen::Vector3d> closest(measured_in_truth.size(),
                                       Eigen::Vector3d::Constant(std::nan("")));
  tbb::parallel_for(size_t{0}, measured_in_truth.size(), [&](size_t i) {
    Eigen::Vector3d q;
    if (std::isfinite(truth.SignedDistance(measured_in_truth[i], max_mm, &q))) closest[i] = q;
  });
  PointCloud surface;
  for (const Eigen::Vector3d& q : closest) {
    if (q.allFinite()) surface.points.push_back(q);
  }
  const MeshIndex mesh(mesh_in_truth);
  f.truth_rms_mm = eval::DeviationFromMesh(surface, mesh).rms_mm;
  return f;
}

}  // namespace fringe::pipeline
