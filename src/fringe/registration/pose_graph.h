// Placement of views from verified pairwise alignments (marker-free registration).
//
// Each edge is one pair's verified relative pose a_from_b with a weight (how much of the pair
// agrees). A single pairwise check can still be wrong on a repetitive scene; a wrong edge,
// however, rarely closes a cycle with right ones. So every triangle of views whose three pairs
// all have an edge is closed (a_from_b * b_from_c * c_from_a should be the identity): its
// rotation angle and the displacement of view a's centre measure the closing error. Then,
// repeatedly, the edge in the most inconsistent triangles (ties: in the fewest consistent ones;
// edges still tied are all rejected, since the triangles cannot tell which is wrong) is
// rejected, until no triangle is inconsistent. Edges between two
// views whose poses are known already (`fixed`) are never rejected. Finally the views are
// placed along a maximum-weight spanning tree grown from the views with known poses (Prim):
// each placed view says the edge that placed it and whether a consistent triangle confirmed
// that edge. A view no kept edge reaches stays unplaced, with the reason.
//
// Only triangles are closed (not longer cycles): views around an object overlap their second
// neighbours too, and a longer cycle with one wrong edge cannot say which edge is wrong.
//
// Frames: a_from_b maps view b's sensor frame into view a's; world_from_view for the results.
// Millimetres. Deterministic; reentrant.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fringe/geometry/rigid3.h"

namespace fringe::registration {

struct PoseGraphEdge {
  int a = 0, b = 0;  // view indices, a != b
  Rigid3d a_from_b;
  double weight = 0;   // > 0; higher is more trusted
  bool fixed = false;  // both poses known already: never rejected
};

struct PoseGraphOptions {
  // A triangle closes when its loop turns by at most this (deg, > 0) and moves the first view's
  // centre by at most max_cycle_mm (> 0).
  double max_cycle_deg = 1.0;
  double max_cycle_mm = 2.0;
  void Check() const;
};

struct PoseGraphResult {
  std::vector<bool> edge_kept;            // per input edge
  std::vector<std::string> edge_message;  // why an edge was rejected (empty when kept)
  std::vector<int> consistent_cycles;     // per edge: closed triangles it belongs to (at the end)
  std::vector<std::optional<Rigid3d>> world_from_view;  // per view; empty when not placed
  std::vector<int> placed_by_edge;        // per view: the edge that placed it, -1 otherwise
  std::vector<std::string> view_message;  // how each view was placed, or why not
  int rejected = 0;
};

// `known_world_from_view` (one per view): the views already placed (at least one, the world);
// `centre_in_view` (one per view): a point of each view's cloud (its centroid) at which the
// closing errors are measured. Throws fringe::Error for bad options, sizes, or edge indices.
PoseGraphResult SolvePoseGraph(const std::vector<std::optional<Rigid3d>>& known_world_from_view,
                               const std::vector<Eigen::Vector3d>& centre_in_view,
                               const std::vector<PoseGraphEdge>& edges,
                               const PoseGraphOptions& options = {});

}  // namespace fringe::registration
