#include "fringe/registration/pose_graph.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "fringe/util/error.h"

namespace fringe::registration {

using util::StrCat;

void PoseGraphOptions::Check() const {
  const char* o = "PoseGraphOptions";
  util::CheckOption(max_cycle_deg > 0, o, "max_cycle_deg", max_cycle_deg, "must be > 0");
  util::CheckOption(max_cycle_mm > 0, o, "max_cycle_mm", max_cycle_mm, "must be > 0");
}

namespace {

// b_from_a of an edge read in the direction from view `from` to the other view.
Rigid3d Toward(const PoseGraphEdge& e, int from) {
  return e.a == from ? e.a_from_b.Inverse() : e.a_from_b;  // other_from_from
}

struct Closure {
  double angle_deg = 0, moved_mm = 0;
};

}  // namespace

PoseGraphResult SolvePoseGraph(const std::vector<std::optional<Rigid3d>>& known_world_from_view,
                               const std::vector<Eigen::Vector3d>& centre_in_view,
                               const std::vector<PoseGraphEdge>& edges,
                               const PoseGraphOptions& options) {
  options.Check();
  const int n = static_cast<int>(known_world_from_view.size());
  if (centre_in_view.size() != known_world_from_view.size()) {
    throw Error(StrCat("SolvePoseGraph: ", centre_in_view.size(), " centres for ", n, " views"));
  }
  const int m = static_cast<int>(edges.size());
  for (int e = 0; e < m; ++e) {
    const PoseGraphEdge& x = edges[e];
    if (x.a < 0 || x.b < 0 || x.a >= n || x.b >= n || x.a == x.b || !(x.weight > 0)) {
      throw Error(StrCat("SolvePoseGraph: edge ", e, " (", x.a, ", ", x.b, ", weight ", x.weight,
                         ") needs two different views in [0, ", n, ") and a weight > 0"));
    }
  }
  PoseGraphResult r;
  r.edge_kept.assign(m, true);
  r.edge_message.assign(m, "");
  r.consistent_cycles.assign(m, 0);
  r.world_from_view.assign(n, std::nullopt);
  r.placed_by_edge.assign(n, -1);
  r.view_message.assign(n, "");

  // Active edges per unordered pair.
  const auto key = [](int a, int b) { return std::make_pair(std::min(a, b), std::max(a, b)); };
  while (true) {
    std::map<std::pair<int, int>, std::vector<int>> of_pair;
    for (int e = 0; e < m; ++e) {
      if (r.edge_kept[e]) of_pair[key(edges[e].a, edges[e].b)].push_back(e);
    }
    std::vector<int> bad(m, 0), good(m, 0);
    std::vector<Closure> worst(m);
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) {
        const auto ij = of_pair.find({i, j});
        if (ij == of_pair.end()) continue;
        for (int k = j + 1; k < n; ++k) {
          const auto jk = of_pair.find({j, k});
          const auto ik = of_pair.find({i, k});
          if (jk == of_pair.end() || ik == of_pair.end()) continue;
          for (int e1 : ij->second) {
            for (int e2 : jk->second) {
              for (int e3 : ik->second) {
                // i -> j -> k -> i: i_from_k * k_from_j * j_from_i.
                const Rigid3d loop =
                    Toward(edges[e3], k) * Toward(edges[e2], j) * Toward(edges[e1], i);
                Closure c;
                c.angle_deg =
                    loop.rotation().angularDistance(Eigen::Quaterniond::Identity()) * 180 / M_PI;
                c.moved_mm = (loop * centre_in_view[i] - centre_in_view[i]).norm();
                const bool closes =
                    c.angle_deg <= options.max_cycle_deg && c.moved_mm <= options.max_cycle_mm;
                for (int e : {e1, e2, e3}) {
                  if (closes) {
                    ++good[e];
                  } else {
                    ++bad[e];
                    if (c.angle_deg + c.moved_mm > worst[e].angle_deg + worst[e].moved_mm) {
                      worst[e] = c;
                    }
                  }
                }
              }
            }
          }
        }
      }
    }
    // The edge in the most triangles that do not close, then in the fewest that do. When
    // several edges tie, the triangles cannot say which of them is wrong: all are rejected
    // (a view may then stay unplaced, never placed by a guess).
    int reject = -1;
    for (int e = 0; e < m; ++e) {
      if (!r.edge_kept[e] || edges[e].fixed || bad[e] == 0) continue;
      if (reject < 0 || bad[e] > bad[reject] || (bad[e] == bad[reject] && good[e] < good[reject])) {
        reject = e;
      }
    }
    if (reject < 0) {
      r.consistent_cycles = good;
      break;
    }
    std::vector<int> tied;
    for (int e = 0; e < m; ++e) {
      if (r.edge_kept[e] && !edges[e].fixed && bad[e] == bad[reject] && good[e] == good[reject]) {
        tied.push_back(e);
      }
    }
    for (int e : tied) {
      r.edge_kept[e] = false;
      ++r.rejected;
      r.edge_message[e] = StrCat(
          "rejected by cycle consistency: ", bad[e], " of its triangles do not close (worst ",
          worst[e].angle_deg, " deg / ", worst[e].moved_mm, " mm; limits ", options.max_cycle_deg,
          " deg / ", options.max_cycle_mm, " mm), ", good[e], " close",
          tied.size() > 1 ? StrCat("; ", tied.size(), " edges tied, all rejected") : "");
    }
  }

  // Prim's maximum-weight spanning tree from the known views.
  bool any_known = false;
  for (int v = 0; v < n; ++v) {
    if (known_world_from_view[v]) {
      r.world_from_view[v] = known_world_from_view[v];
      r.view_message[v] = "known";
      any_known = true;
    }
  }
  if (!any_known) throw Error("SolvePoseGraph: no view has a known pose (the world is undefined)");
  while (true) {
    int best = -1, from = -1, to = -1;
    for (int e = 0; e < m; ++e) {
      if (!r.edge_kept[e]) continue;
      const bool pa = r.world_from_view[edges[e].a].has_value();
      const bool pb = r.world_from_view[edges[e].b].has_value();
      if (pa == pb) continue;
      if (best < 0 || edges[e].weight > edges[best].weight) {
        best = e;
        from = pa ? edges[e].a : edges[e].b;
        to = pa ? edges[e].b : edges[e].a;
      }
    }
    if (best < 0) break;
    r.world_from_view[to] = *r.world_from_view[from] * Toward(edges[best], from).Inverse();
    r.placed_by_edge[to] = best;
    r.view_message[to] =
        StrCat("placed from view ", from, " (weight ", edges[best].weight, "; ",
               r.consistent_cycles[best] > 0
                   ? StrCat("confirmed by ", r.consistent_cycles[best], " closed triangles")
                   : std::string("in no triangle: not confirmed by a cycle"),
               ")");
  }
  for (int v = 0; v < n; ++v) {
    if (r.world_from_view[v]) continue;
    int edges_of_v = 0, rejected_of_v = 0;
    for (int e = 0; e < m; ++e) {
      if (edges[e].a != v && edges[e].b != v) continue;
      ++edges_of_v;
      rejected_of_v += !r.edge_kept[e];
    }
    r.view_message[v] = edges_of_v == 0
                            ? std::string("no verified pairwise alignment with any view")
                        : rejected_of_v == edges_of_v
                            ? StrCat("all of its ", edges_of_v,
                                     " verified pairwise alignments were rejected by "
                                     "cycle consistency")
                            : "its verified alignments reach no view connected to the world";
  }
  return r;
}

}  // namespace fringe::registration
