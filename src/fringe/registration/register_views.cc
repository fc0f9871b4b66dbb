#include "fringe/registration/register_views.h"

#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "fringe/registration/free_space.h"
#include "fringe/registration/pose_graph.h"
#include "fringe/registration/surface_noise.h"
#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::registration {

using Eigen::Vector3d;
using util::StrCat;

void RegistrationOptions::Check() const {
  const char* o = "RegistrationOptions";
  util::CheckOption(min_extent_mm > 0, o, "min_extent_mm", min_extent_mm, "must be > 0");
  util::CheckOption(icp_threshold_factor > 0, o, "icp_threshold_factor", icp_threshold_factor,
                    "must be > 0");
  util::CheckOption(icp_min_start_threshold_mm > 0, o, "icp_min_start_threshold_mm",
                    icp_min_start_threshold_mm, "must be > 0");
  util::CheckOption(coarse_verify_min_overlap > 0 && coarse_verify_min_overlap <= 1, o,
                    "coarse_verify_min_overlap", coarse_verify_min_overlap, "must be in (0, 1]");
  util::CheckOption(coarse_verify_tolerance_factor > 0, o, "coarse_verify_tolerance_factor",
                    coarse_verify_tolerance_factor, "must be > 0");
  util::CheckOption(coarse_max_inconsistent >= 0 && coarse_max_inconsistent < 1, o,
                    "coarse_max_inconsistent", coarse_max_inconsistent, "must be in [0, 1)");
  util::CheckOption(coarse_max_free_space >= 0 && coarse_max_free_space < 1, o,
                    "coarse_max_free_space", coarse_max_free_space, "must be in [0, 1)");
  util::CheckOption(coarse_min_gap > 0 && coarse_min_gap < 1, o, "coarse_min_gap", coarse_min_gap,
                    "must be in (0, 1)");
  util::CheckOption(coarse_same_pose_deg > 0, o, "coarse_same_pose_deg", coarse_same_pose_deg,
                    "must be > 0");
  util::CheckOption(coarse_same_pose_mm > 0, o, "coarse_same_pose_mm", coarse_same_pose_mm,
                    "must be > 0");
  util::CheckOption(coarse_icp_normal_spread_deg >= 0 && coarse_icp_normal_spread_deg < 180, o,
                    "coarse_icp_normal_spread_deg", coarse_icp_normal_spread_deg,
                    "must be in [0, 180)");
  matching.Check();
  pose_graph.Check();
  adjustment.Check();
  coarse.Check();
  icp.Check();
  marker_free_icp.Check();
}

const char* ToString(ViewPath p) {
  switch (p) {
    case ViewPath::kWorld:
      return "world";
    case ViewPath::kMarkers:
      return "markers";
    case ViewPath::kInitial:
      return "initial pose";
    case ViewPath::kMarkerFree:
      return "marker-free";
    case ViewPath::kUnplaced:
      return "unplaced";
    case ViewPath::kBadInput:
      return "bad input";
  }
  return "?";
}

const char* ToString(RegistrationStatus s) {
  switch (s) {
    case RegistrationStatus::kOk:
      return "ok";
    case RegistrationStatus::kPartial:
      return "partial";
    case RegistrationStatus::kFailed:
      return "failed";
  }
  return "?";
}

std::string RegistrationSummary::BriefReport() const {
  std::string s = StrCat("registration: ", ToString(status), ", ", placed, " views placed, ",
                         unplaced, " unplaced, ", bad_input, " bad input, ", seconds, " s");
  if (!message.empty()) s += ": " + message;
  return s;
}

namespace {

// A grid lists one slot inside it per cloud point (RefineMultiView would throw otherwise).
bool GridFits(const ViewGrid& g, size_t points) {
  const size_t slots = static_cast<size_t>(g.projection.width()) * g.projection.height();
  if (g.slot_of_point.size() != points) return false;
  for (uint32_t s : g.slot_of_point) {
    if (s >= slots) return false;
  }
  return true;
}

// Normal-space samples measured per marker-free candidate.
constexpr int kVerifySamples = 5000;

class Registrar {
 public:
  Registrar(const std::vector<RegistrationView>& views, const RegistrationOptions& options)
      : in_(views), o_(options), n_(static_cast<int>(views.size())) {
    r_.views.resize(n_);
  }

  RegistrationResult Run() {
    util::Timer timer;
    CheckInputs();
    int world = -1;
    for (int v = 0; v < n_ && world < 0; ++v) {
      if (r_.views[v].path != ViewPath::kBadInput) world = v;
    }
    if (world < 0) {
      Finish(timer, "no usable view");
      return std::move(r_);
    }
    world_ = world;
    ViewRegistration& w = r_.views[world];
    w.path = ViewPath::kWorld;
    w.world_from_sensor = in_[world].initial_world_from_sensor.value_or(Rigid3d());
    w.world_from_sensor_markers = w.world_from_sensor_adjusted = w.world_from_sensor;
    w.message = "defines the world frame";
    if (o_.use_markers) AddToMap(world, {});
    for (int v = 0; v < n_; ++v) {
      if (v == world || r_.views[v].path != ViewPath::kUnplaced) continue;
      if (in_[v].initial_world_from_sensor) {
        ViewRegistration& vr = r_.views[v];
        vr.path = ViewPath::kInitial;
        vr.world_from_sensor = vr.world_from_sensor_markers = vr.world_from_sensor_adjusted =
            *in_[v].initial_world_from_sensor;
        vr.message = "placed by its initial pose";
      }
    }
    if (o_.use_markers) PlaceByMarkers();
    if (o_.coarse_fallback) PlaceMarkerFree();
    for (ViewRegistration& vr : r_.views) {
      if (vr.path == ViewPath::kUnplaced && vr.message.empty()) {
        vr.message = "no markers shared with the map and no marker-free alignment tried";
      }
    }
    if (o_.use_markers && o_.adjust_markers) Adjust();
    for (ViewRegistration& vr : r_.views) vr.world_from_sensor_adjusted = vr.world_from_sensor;
    if (o_.refine_icp) Refine();
    Finish(timer, "");
    return std::move(r_);
  }

 private:
  void CheckInputs() {
    for (int v = 0; v < n_; ++v) {
      ViewRegistration& vr = r_.views[v];
      const RegistrationView& in = in_[v];
      vr.name = in.name;
      vr.markers = static_cast<int>(in.markers.size());
      vr.path = ViewPath::kUnplaced;
      if (in.cloud.empty()) {
        vr.path = ViewPath::kBadInput;
        vr.message = "empty cloud";
        continue;
      }
      if (!in.cloud.has_normals()) {
        vr.path = ViewPath::kBadInput;
        vr.message = "the cloud has no normals (estimate them first)";
        continue;
      }
      if (in.grid && !GridFits(*in.grid, in.cloud.size())) {
        vr.path = ViewPath::kBadInput;
        vr.message = StrCat("its grid (", in.grid->slot_of_point.size(), " slots of ",
                            in.grid->projection.width(), "x", in.grid->projection.height(),
                            ") does not fit its ", in.cloud.size(), " points");
        continue;
      }
      Vector3d lo, hi;
      in.cloud.Bounds(&lo, &hi);
      const double extent = (hi - lo).norm();
      if (!std::isfinite(extent) || extent < o_.min_extent_mm) {
        vr.path = ViewPath::kBadInput;
        vr.message = StrCat("the cloud is ", extent,
                            " across: too small for millimetres; are "
                            "its units metres? (fringe register --units m)");
      }
    }
  }

  std::vector<MarkerPoint> ViewPoints(int v) const {
    std::vector<MarkerPoint> pts;
    for (const ViewMarker& m : in_[v].markers) {
      pts.push_back({m.centre_in_sensor, m.normal_in_sensor, std::max(m.sigma_mm, 1e-3),
                     CentreCovariance(m)});
    }
    return pts;
  }
  std::vector<MarkerPoint> MapPoints() const {
    std::vector<MarkerPoint> pts;
    for (const MapMarker& m : r_.map)
      pts.push_back({m.centre_in_world, m.normal_in_world, m.sigma_mm, m.covariance_in_world});
    return pts;
  }

  // Adds view v's sightings to the map: matched markers to their map marker (centre re-averaged
  // over all its sightings), the others as new map markers.
  void AddToMap(int v, const std::vector<std::pair<int, int>>& pairs) {
    std::vector<int> map_of(in_[v].markers.size(), -1);
    for (const auto& [k, m] : pairs) map_of[k] = m;
    for (size_t k = 0; k < in_[v].markers.size(); ++k) {
      int m = map_of[k];
      if (m < 0) {
        MapMarker mm;
        mm.id = static_cast<int>(r_.map.size());
        mm.outer_radius_mm = in_[v].markers[k].outer_radius_mm;
        r_.map.push_back(mm);
        m = mm.id;
      }
      r_.map[m].sightings.push_back({v, static_cast<int>(k)});
      UpdateMapMarker(m);
    }
  }
  // The centre: the sightings' information-weighted mean (each sighting's covariance turned
  // into the world frame: views see a marker along different rays, and each is most certain
  // across its own ray).
  void UpdateMapMarker(int m) {
    MapMarker& mm = r_.map[m];
    Vector3d nsum = Vector3d::Zero(), weighted = Vector3d::Zero();
    Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
    for (const auto& s : mm.sightings) {
      const Rigid3d& pose = r_.views[s.view].world_from_sensor;
      const ViewMarker& vm = in_[s.view].markers[s.view_marker];
      const Eigen::Matrix3d R = pose.rotation_matrix();
      const Eigen::Matrix3d w = (R * CentreCovariance(vm) * R.transpose()).inverse();
      info += w;
      weighted += w * (pose * vm.centre_in_sensor);
      nsum += pose.RotateDirection(vm.normal_in_sensor);
    }
    mm.covariance_in_world = info.inverse();
    mm.centre_in_world = mm.covariance_in_world * weighted;
    mm.normal_in_world = nsum.norm() > 0 ? Vector3d(nsum.normalized()) : Vector3d::UnitZ();
    mm.sigma_mm = std::sqrt(mm.covariance_in_world.trace());
  }

  void PlaceByMarkers() {
    std::vector<std::string> last(n_);
    while (true) {
      int best = -1;
      MarkerMatchResult best_match;
      const std::vector<MarkerPoint> map = MapPoints();
      // The pending views are matched against the map concurrently (MatchMarkers is reentrant
      // and deterministic); the best is then chosen in view order, as before.
      std::vector<int> pending;
      for (int v = 0; v < n_; ++v) {
        if (r_.views[v].path != ViewPath::kUnplaced) continue;
        if (in_[v].markers.size() < 3) {
          last[v] = StrCat("only ", in_[v].markers.size(), " markers");
          continue;
        }
        pending.push_back(v);
      }
      std::vector<MarkerMatchResult> matches(pending.size());
      tbb::parallel_for(size_t{0}, pending.size(), [&](size_t k) {
        matches[k] = MatchMarkers(ViewPoints(pending[k]), map, o_.matching);
      });
      for (size_t k = 0; k < pending.size(); ++k) {
        const int v = pending[k];
        MarkerMatchResult& m = matches[k];
        last[v] = m.BriefReport();
        if (m.ok() && (best < 0 || m.pairs.size() > best_match.pairs.size())) {
          best = v;
          best_match = std::move(m);
        }
      }
      if (best < 0) break;
      ViewRegistration& vr = r_.views[best];
      vr.path = ViewPath::kMarkers;
      vr.world_from_sensor = vr.world_from_sensor_markers = best_match.map_from_view;
      vr.matched_markers = static_cast<int>(best_match.pairs.size());
      vr.marker_rms_mm = best_match.rms_mm;
      vr.message = best_match.BriefReport();
      AddToMap(best, best_match.pairs);
    }
    for (int v = 0; v < n_; ++v) {
      if (r_.views[v].path == ViewPath::kUnplaced) r_.views[v].message = last[v];
    }
  }

  // Marker-free placement (issue 29): pairwise candidates for every pair of views with at least
  // one view still to place, each pair verified on its own (CheckPair), then a pose graph over
  // the verified pairs (pose_graph.h: triangles that do not close reject their wrong edge) places
  // the pending views along its strongest edges from the views placed already.
  void PlaceMarkerFree() {
    std::vector<int> pending, usable;
    for (int v = 0; v < n_; ++v) {
      if (r_.views[v].path == ViewPath::kBadInput) continue;
      usable.push_back(v);
      if (r_.views[v].path == ViewPath::kUnplaced) pending.push_back(v);
    }
    if (pending.empty()) return;
    features_.resize(n_);
    noise_.assign(n_, 0.0);
    for (int v : usable) {
      features_[v] = std::make_unique<CoarseFeatures>(in_[v].cloud, o_.coarse);
      noise_[v] = EstimateSurfaceNoiseMm(in_[v].cloud, 1000, 16, o_.icp.seed);
      r_.views[v].surface_noise_mm = noise_[v];
    }
    std::vector<PoseGraphEdge> edges;
    std::vector<std::string> pair_notes(n_);
    for (size_t i = 0; i < usable.size(); ++i) {
      for (size_t j = i + 1; j < usable.size(); ++j) {
        const int a = usable[i], b = usable[j];
        if (r_.views[a].placed() && r_.views[b].placed()) {
          // Both known: their relative pose closes triangles with the pending views' pairs.
          edges.push_back({a, b,
                           r_.views[a].world_from_sensor.Inverse() * r_.views[b].world_from_sensor,
                           1.0, true});
          continue;
        }
        const PairCheck pc = CheckPair(a, b);
        const std::string note = StrCat("with ", in_[a].name, ": ", pc.message);
        for (int v : {a, b}) {
          if (r_.views[v].placed()) continue;
          pair_notes[v] += (pair_notes[v].empty() ? "" : "; ") +
                           (v == a ? StrCat("with ", in_[b].name, ": ", pc.message) : note);
        }
        if (pc.verified) edges.push_back({a, b, pc.a_from_b, pc.weight, false});
      }
    }
    std::vector<std::optional<Rigid3d>> known(n_);
    std::vector<Vector3d> centres(n_, Vector3d::Zero());
    for (int v : usable) {
      if (r_.views[v].placed()) known[v] = r_.views[v].world_from_sensor;
      Vector3d c = Vector3d::Zero();
      for (const Vector3d& p : in_[v].cloud.points) c += p;
      centres[v] = c / static_cast<double>(in_[v].cloud.size());
    }
    const PoseGraphResult g = SolvePoseGraph(known, centres, edges, o_.pose_graph);
    std::vector<std::string> rejected(n_);
    for (size_t e = 0; e < edges.size(); ++e) {
      if (g.edge_kept[e]) continue;
      for (int v : {edges[e].a, edges[e].b}) {
        const int other = v == edges[e].a ? edges[e].b : edges[e].a;
        rejected[v] += StrCat("; edge with ", in_[other].name, " ", g.edge_message[e]);
      }
    }
    for (int v : pending) {
      ViewRegistration& vr = r_.views[v];
      const std::string why = vr.message.empty() ? "" : vr.message + "; ";
      std::string graph = g.view_message[v];
      if (g.placed_by_edge[v] >= 0) {
        const PoseGraphEdge& e = edges[g.placed_by_edge[v]];
        const int from = e.a == v ? e.b : e.a;
        graph = StrCat("placed from ", in_[from].name,
                       g.view_message[v].substr(g.view_message[v].find(" (")));
      }
      vr.message = StrCat(why, "pairs: ", pair_notes[v], rejected[v], "; pose graph: ", graph);
      if (!g.world_from_view[v]) {
        vr.message += "; cannot place";
        continue;
      }
      vr.path = ViewPath::kMarkerFree;
      vr.world_from_sensor = vr.world_from_sensor_markers = *g.world_from_view[v];
    }
  }

  struct PairCheck {
    bool verified = false;
    Rigid3d a_from_b;
    double weight = 0;
    std::string message;
  };

  // One pair's marker-free alignment, verified. The coarse candidates (coarse.h: the best RANSAC
  // alignment and the best different ones) of b onto a are each refined by pairwise ICP (all
  // directions free: a held direction would keep the coarse error; samples only where the
  // normals are smooth, coarse_icp_normal_spread_deg: on the 8-view plate scene, half rig, the
  // rims' smeared normals otherwise slide every pair ~1.5 mm along the plate, 5 of 8 views
  // then placed wrong; with them left out 0 wrong, 0.96 mm) and then measured:
  //  - MeasureAgreement (icp.h) on b's normal-space samples: `overlap` within 3 voxels of a,
  //    `consistent` (fraction of all samples within one voxel of a, within
  //    coarse_verify_tolerance_factor x the two views' combined noise (surface_noise.h) of a's
  //    surface and with agreeing normals) and `inconsistent` (fraction of the samples within one
  //    voxel that fail);
  //  - `free space` (free_space.h), when both views carry their grids: the larger of the two
  //    directions' fractions of samples lying where the other camera saw through.
  // A candidate's conflict is inconsistent + free space. The candidate with overlap >=
  // coarse_verify_min_overlap and the highest consistent x (1 - conflict) is the pair's pose when
  //  (a) its ICP left no direction unconstrained (IcpSchedule::degeneracy_ratio), its
  //      inconsistent fraction is <= coarse_max_inconsistent and its free-space fraction <=
  //      coarse_max_free_space, and
  //  (b) every candidate refined to a DIFFERENT pose (beyond coarse_same_pose_deg / _mm) with
  //      that overlap conflicts more by coarse_min_gap, or has fewer consistent samples by
  //      coarse_min_gap (of all samples).
  // A symmetric or featureless pair has two equally good answers and gives no edge, never a
  // confidently wrong one. The edge's weight: the consistent samples.
  PairCheck CheckPair(int a, int b) const {
    PairCheck out;
    const CoarseResult c = AlignCoarse(*features_[b], *features_[a], o_.coarse);
    if (!c.ok()) {
      out.message = c.BriefReport();
      return out;
    }
    IcpOptions io;  // every direction free (see above); the schedule of the callers' ICP
    io.points_per_level = o_.icp.points_per_level;
    io.seed = o_.icp.seed;
    io.initial_threshold_mm = std::max(o_.icp.initial_threshold_mm, 3 * o_.coarse.voxel_mm);
    io.sample_max_normal_spread_deg = o_.coarse_icp_normal_spread_deg;
    const PointCloud& ca = in_[a].cloud;
    const PointCloud& cb = in_[b].cloud;
    std::vector<Rigid3d> refined;
    std::vector<int> degenerate;
    for (const CoarseCandidate& cand : c.candidates) {
      const IcpResult icp = AlignPointToPlane(cb, ca, cand.target_from_source, io);
      if (icp.summary.status == IcpStatus::kNoOverlap || icp.summary.levels.empty()) continue;
      refined.push_back(icp.world_from_sensor[1]);
      degenerate.push_back(icp.summary.levels.back().degenerate_directions);
    }
    if (refined.empty()) {
      out.message = StrCat(c.BriefReport(), "; no candidate overlaps after ICP");
      return out;
    }
    // From the two views' noise, not the pair's ICP residual (large exactly when it is wrong);
    // never below a 1000th of the voxel (noise-free synthetic views).
    const double tolerance = o_.coarse_verify_tolerance_factor *
                             std::max(std::hypot(noise_[a], noise_[b]), 1e-3 * o_.coarse.voxel_mm);
    // Uniform samples for the absolute test (a right pose of real scans disagrees most at the
    // grazing edges, which normal-space samples favour: bunny pairs 9-23 % inconsistent, uniform
    // 4-14 %); normal-space ones to rank the candidates (on a plate-dominated scene the objects
    // that tell them apart are a few % of uniform samples).
    const std::vector<SurfaceAgreement> agree =
        MeasureAgreement(cb, ca, refined, kVerifySamples, 3 * o_.coarse.voxel_mm,
                         o_.coarse.voxel_mm, tolerance, io.max_normal_angle_deg, io.seed, false);
    const std::vector<SurfaceAgreement> rank =
        MeasureAgreement(cb, ca, refined, kVerifySamples, 3 * o_.coarse.voxel_mm,
                         o_.coarse.voxel_mm, tolerance, io.max_normal_angle_deg, io.seed, true);
    std::vector<double> free_space(refined.size(), 0.0);
    if (in_[a].grid && in_[b].grid) {
      std::vector<Rigid3d> inverse;
      for (const Rigid3d& t : refined) inverse.push_back(t.Inverse());
      const auto ab =
          CheckFreeSpace(cb, ca, *in_[a].grid, refined, kVerifySamples, tolerance, io.seed);
      const auto ba =
          CheckFreeSpace(ca, cb, *in_[b].grid, inverse, kVerifySamples, tolerance, io.seed);
      for (size_t k = 0; k < refined.size(); ++k) {
        free_space[k] = std::max(ab[k].fraction(), ba[k].fraction());
      }
    }
    std::vector<double> conflict(refined.size()), score(refined.size());
    for (size_t k = 0; k < refined.size(); ++k) {
      conflict[k] = rank[k].inconsistent + free_space[k];
      score[k] = rank[k].consistent * std::max(0.0, 1 - conflict[k]);
    }
    int best = -1;
    for (int k = 0; k < static_cast<int>(refined.size()); ++k) {
      if (agree[k].overlap < o_.coarse_verify_min_overlap) continue;
      if (best < 0 || score[k] > score[best]) best = k;
    }
    out.message = StrCat(c.candidates.size(), " RANSAC candidates refined by ICP (tolerance ",
                         tolerance, " mm)");
    if (best < 0) {
      out.message +=
          StrCat(": no candidate overlaps by ", o_.coarse_verify_min_overlap, " or more");
      return out;
    }
    int rival = -1;  // the different pose least ruled out
    for (int k = 0; k < static_cast<int>(refined.size()); ++k) {
      const RigidDifference d = Difference(refined[k], refined[best]);
      if (k == best || agree[k].overlap < o_.coarse_verify_min_overlap ||
          (d.angle_rad * 180 / M_PI < o_.coarse_same_pose_deg &&
           d.translation_mm < o_.coarse_same_pose_mm)) {
        continue;
      }
      if (rival < 0 || score[k] > score[rival]) rival = k;
    }
    out.message +=
        StrCat(": best overlap ", agree[best].overlap, ", inconsistent ", agree[best].inconsistent,
               ", free space ", free_space[best], ", normal-space consistent ",
               rank[best].consistent, " / inconsistent ", rank[best].inconsistent);
    if (rival >= 0) {
      out.message += StrCat("; best different pose: free space ", free_space[rival],
                            ", normal-space consistent ", rank[rival].consistent,
                            " / inconsistent ", rank[rival].inconsistent);
    }
    if (degenerate[best] > 0) {
      out.message += StrCat(": no edge (the overlap leaves ", degenerate[best],
                            " directions unconstrained: a plane, sphere or cylinder)");
      return out;
    }
    if (agree[best].inconsistent > o_.coarse_max_inconsistent) {
      out.message += StrCat(": no edge (inconsistent beyond ", o_.coarse_max_inconsistent, ")");
      return out;
    }
    if (free_space[best] > o_.coarse_max_free_space) {
      out.message += StrCat(": no edge (free space beyond ", o_.coarse_max_free_space, ")");
      return out;
    }
    if (rival >= 0 && conflict[rival] - conflict[best] < o_.coarse_min_gap &&
        rank[best].consistent - rank[rival].consistent < o_.coarse_min_gap) {
      out.message += ": no edge (a different pose fits about as well: symmetric or featureless)";
      return out;
    }
    out.verified = true;
    out.a_from_b = refined[best];
    out.weight = rank[best].consistent * kVerifySamples;
    out.message += ": edge";
    return out;
  }

  void Adjust() {
    std::vector<MarkerSighting> sightings;
    std::vector<Rigid3d> poses(n_);
    std::vector<bool> fixed(n_, true);
    int marker_views = 0;
    for (int v = 0; v < n_; ++v) {
      poses[v] = r_.views[v].world_from_sensor;
      if (r_.views[v].path == ViewPath::kMarkers) {
        fixed[v] = false;
        ++marker_views;
      }
    }
    if (marker_views == 0) {
      r_.summary.adjustment.status = AdjustmentStatus::kNothingToAdjust;
      r_.summary.adjustment.message = "no view placed by markers";
      return;
    }
    std::vector<Vector3d> centres;
    for (const MapMarker& m : r_.map) {
      centres.push_back(m.centre_in_world);
      for (const auto& s : m.sightings) {
        const ViewMarker& vm = in_[s.view].markers[s.view_marker];
        sightings.push_back(
            {s.view, m.id, vm.centre_in_sensor, std::max(vm.sigma_mm, 1e-3), CentreCovariance(vm)});
      }
    }
    const AdjustmentResult a = AdjustMarkers(poses, centres, sightings, fixed, o_.adjustment);
    r_.summary.adjustment = a.summary;
    if (a.summary.status == AdjustmentStatus::kNothingToAdjust) return;
    for (int v = 0; v < n_; ++v) r_.views[v].world_from_sensor = a.world_from_sensor[v];
    for (size_t m = 0; m < r_.map.size(); ++m) r_.map[m].centre_in_world = a.markers_in_world[m];
    std::vector<double> ss(n_, 0.0);
    std::vector<int> cnt(n_, 0);
    for (const MarkerSighting& s : sightings) {
      const double d =
          (a.world_from_sensor[s.view] * s.centre_in_sensor - a.markers_in_world[s.marker]).norm();
      ss[s.view] += d * d;
      ++cnt[s.view];
    }
    for (int v = 0; v < n_; ++v) {
      if (cnt[v] > 0) r_.views[v].adjusted_rms_mm = std::sqrt(ss[v] / cnt[v]);
    }
  }

  void Refine() {
    std::vector<int> ids;
    double start = o_.icp_min_start_threshold_mm;
    // What the marker fits bound the views' misalignment by (the first threshold before its
    // floor, which is for the spacing and noise); unknown (0) once a view was placed otherwise.
    double misalignment = 0;
    bool markers_only = true;
    for (int v = 0; v < n_; ++v) {
      const ViewRegistration& vr = r_.views[v];
      if (!vr.placed()) continue;
      ids.push_back(v);
      if (vr.path == ViewPath::kMarkers) {
        const double bound =
            o_.icp_threshold_factor * std::max(vr.marker_rms_mm, vr.adjusted_rms_mm);
        start = std::max(start, bound);
        misalignment = std::max(misalignment, bound);
      } else if (vr.path != ViewPath::kWorld) {
        markers_only = false;
      }
    }
    if (ids.size() < 2) {
      r_.summary.icp.status = IcpStatus::kNoOverlap;
      r_.summary.icp.message = "fewer than two placed views";
      return;
    }
    std::vector<IcpView> iv;
    for (int v : ids) {
      IcpView x;
      x.cloud = &in_[v].cloud;
      x.grid = in_[v].grid ? &*in_[v].grid : nullptr;
      x.world_from_sensor = r_.views[v].world_from_sensor;
      x.fixed = v == world_;
      iv.push_back(x);
    }
    IcpOptions io = markers_only ? o_.icp : o_.marker_free_icp;
    // marker_free_icp's 10 deg normal test is for grid views, whose normals come from the
    // grid's neighbours at the sensor's precision. An unorganized scan's normals are estimated
    // from its nearest points, and on a real one (bunny, 4 scans) 10 deg rejects good pairs in
    // its noise: pair RMS 0.18803 mm (Open3D multiway 0.18733), 0.18656 with `icp`'s 45 deg
    // (relaxing instead the trimming, the smooth-sample or the coverage test: 0.1900, 0.1877,
    // 0.1878 mm). Without marker_free_icp at all the slide along a plate stays (the test
    // RefinementWithoutMarkersRemovesASlideAlongAPlate, unorganized views, fails).
    bool all_grids = true;
    for (int v : ids) all_grids = all_grids && in_[v].grid.has_value();
    if (!markers_only && !all_grids) io.max_normal_angle_deg = o_.icp.max_normal_angle_deg;
    if (!markers_only) start = std::max(start, io.initial_threshold_mm);
    io.initial_threshold_mm = start;
    io.min_threshold_mm = std::min(io.min_threshold_mm, start);
    io.start_misalignment_mm = markers_only ? misalignment : 0.0;
    const IcpResult res = RefineMultiView(iv, io);
    r_.summary.icp = res.summary;
    if (res.summary.status == IcpStatus::kNoOverlap) return;
    for (size_t k = 0; k < ids.size(); ++k) {
      ViewRegistration& vr = r_.views[ids[k]];
      vr.world_from_sensor = res.world_from_sensor[k];
      double best = 0;
      for (size_t j = 0; j < ids.size(); ++j) {
        if (j != k) best = std::max(best, res.overlap[k][j]);
      }
      vr.overlap_fraction = best;
    }
  }

  void Finish(const util::Timer& timer, const std::string& message) {
    RegistrationSummary& s = r_.summary;
    s.placed = s.unplaced = s.bad_input = 0;
    for (const ViewRegistration& vr : r_.views) {
      if (vr.placed()) ++s.placed;
      if (vr.path == ViewPath::kUnplaced) ++s.unplaced;
      if (vr.path == ViewPath::kBadInput) ++s.bad_input;
    }
    s.status = s.placed == 0    ? RegistrationStatus::kFailed
               : s.placed == n_ ? RegistrationStatus::kOk
                                : RegistrationStatus::kPartial;
    s.message = message;
    if (s.message.empty() && s.status != RegistrationStatus::kOk) {
      s.message = StrCat(n_ - s.placed, " of ", n_, " views not placed");
    }
    s.seconds = timer.ElapsedSeconds();
  }

  const std::vector<RegistrationView>& in_;
  const RegistrationOptions& o_;
  int n_;
  int world_ = -1;
  RegistrationResult r_;
  std::vector<std::unique_ptr<CoarseFeatures>> features_;  // per view, marker-free path only
  std::vector<double> noise_;                              // per view (surface_noise.h), same
};

}  // namespace

RegistrationResult RegisterViews(const std::vector<RegistrationView>& views,
                                 const RegistrationOptions& options) {
  options.Check();
  return Registrar(views, options).Run();
}

}  // namespace fringe::registration
