#include "fringe/registration/register_views.h"

#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

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
  util::CheckOption(coarse_min_gap > 0 && coarse_min_gap < 1, o, "coarse_min_gap", coarse_min_gap,
                    "must be in (0, 1)");
  util::CheckOption(coarse_same_pose_deg > 0, o, "coarse_same_pose_deg", coarse_same_pose_deg,
                    "must be > 0");
  util::CheckOption(coarse_same_pose_mm > 0, o, "coarse_same_pose_mm", coarse_same_pose_mm,
                    "must be > 0");
  matching.Check();
  adjustment.Check();
  coarse.Check();
  icp.Check();
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

  // The placed views' clouds in the world frame, thinned to about max_points.
  PointCloud PlacedCloud(size_t max_points) const {
    size_t total = 0;
    for (int v = 0; v < n_; ++v) {
      if (r_.views[v].placed()) total += in_[v].cloud.size();
    }
    const size_t stride = std::max<size_t>(1, total / max_points);
    PointCloud out;
    out.normals.reserve(total / stride + 1);
    for (int v = 0; v < n_; ++v) {
      if (!r_.views[v].placed()) continue;
      const Rigid3d& pose = r_.views[v].world_from_sensor;
      for (size_t i = 0; i < in_[v].cloud.size(); i += stride) {
        out.points.push_back(pose * in_[v].cloud.points[i]);
        out.normals.push_back(pose.RotateDirection(in_[v].cloud.normals[i]));
      }
    }
    return out;
  }

  // Marker-free placement, verified. The coarse candidates (coarse.h: the best RANSAC
  // alignment and the best different ones) are each refined by pairwise ICP against the placed
  // clouds and then measured (MeasureAgreement, icp.h) on normal-space samples, so that the
  // walls and objects count as much as a dominant plate: `inconsistent` is the fraction of the
  // samples in the overlap whose distance to the placed surface exceeds
  // coarse_verify_tolerance_factor x the smallest ICP RMS, or whose normals disagree. The most
  // consistent candidate with overlap >= coarse_verify_min_overlap is placed only when
  //  (a) its inconsistent fraction is <= coarse_max_inconsistent, and
  //  (b) every candidate refined to a DIFFERENT pose (beyond coarse_same_pose_deg / _mm) with
  //      overlap >= coarse_verify_min_overlap is more inconsistent by coarse_min_gap or more.
  // A symmetric or featureless view has two equally consistent answers and is reported
  // "cannot place", never placed confidently wrong (an 82 deg turn of a plate-dominated view
  // overlaps the plate as well as the right pose does: only the objects tell them apart).
  void PlaceMarkerFree() {
    bool progress = true;
    while (progress) {
      progress = false;
      for (int v = 0; v < n_; ++v) {
        if (r_.views[v].path != ViewPath::kUnplaced) continue;
        const PointCloud target = PlacedCloud(400000);
        const CoarseResult c = AlignCoarse(in_[v].cloud, target, o_.coarse);
        ViewRegistration& vr = r_.views[v];
        const std::string why = vr.message.empty() ? "" : vr.message + "; ";
        if (!c.ok()) {
          vr.message = why + c.BriefReport();
          continue;
        }
        IcpOptions io = o_.icp;
        io.initial_threshold_mm = std::max(io.initial_threshold_mm, 3 * o_.coarse.voxel_mm);
        std::vector<Rigid3d> refined;
        double min_rms = std::numeric_limits<double>::infinity();
        for (const CoarseCandidate& cand : c.candidates) {
          const IcpResult icp =
              AlignPointToPlane(in_[v].cloud, target, cand.target_from_source, io);
          if (icp.summary.status == IcpStatus::kNoOverlap || icp.summary.levels.empty()) continue;
          refined.push_back(icp.world_from_sensor[1]);
          min_rms = std::min(min_rms, icp.summary.levels.back().rms_end_mm);
        }
        const double tolerance = o_.coarse_verify_tolerance_factor * min_rms;
        const std::vector<SurfaceAgreement> agree =
            MeasureAgreement(in_[v].cloud, target, refined, kVerifySamples, 3 * o_.coarse.voxel_mm,
                             tolerance, io.max_normal_angle_deg, io.seed);
        int best = -1;
        for (int k = 0; k < static_cast<int>(refined.size()); ++k) {
          if (agree[k].overlap < o_.coarse_verify_min_overlap) continue;
          if (best < 0 || agree[k].inconsistent < agree[best].inconsistent) best = k;
        }
        std::string verdict = StrCat(c.BriefReport(), "; ", refined.size(),
                                     " candidates refined by ICP (tolerance ", tolerance, " mm)");
        std::string refusal;
        if (best < 0) {
          refusal = StrCat("no candidate overlaps the placed views by ",
                           o_.coarse_verify_min_overlap, " or more");
        } else {
          double rival = 1;
          for (int k = 0; k < static_cast<int>(refined.size()); ++k) {
            const RigidDifference d = Difference(refined[k], refined[best]);
            if (agree[k].overlap < o_.coarse_verify_min_overlap ||
                (d.angle_rad * 180 / M_PI < o_.coarse_same_pose_deg &&
                 d.translation_mm < o_.coarse_same_pose_mm)) {
              continue;
            }
            rival = std::min(rival, agree[k].inconsistent);
          }
          verdict += StrCat(": best overlap ", agree[best].overlap, ", inconsistent ",
                            agree[best].inconsistent, "; best different pose inconsistent ", rival);
          if (agree[best].inconsistent > o_.coarse_max_inconsistent) {
            refusal = StrCat("the best pose is inconsistent beyond ", o_.coarse_max_inconsistent);
          } else if (rival - agree[best].inconsistent < o_.coarse_min_gap) {
            refusal = "a different pose fits about as well (a symmetric or featureless view)";
          }
        }
        if (!refusal.empty()) {
          vr.message = StrCat(why, verdict, "; cannot place: ", refusal);
          continue;
        }
        vr.path = ViewPath::kMarkerFree;
        vr.world_from_sensor = vr.world_from_sensor_markers = refined[best];
        vr.message = StrCat(why, verdict, "; placed");
        progress = true;
      }
    }
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
        start = std::max(start, o_.icp.initial_threshold_mm);
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
    IcpOptions io = o_.icp;
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
};

}  // namespace

RegistrationResult RegisterViews(const std::vector<RegistrationView>& views,
                                 const RegistrationOptions& options) {
  options.Check();
  return Registrar(views, options).Run();
}

}  // namespace fringe::registration
