#include "fringe/registration/free_space.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "fringe/util/error.h"

namespace fringe::registration {

std::vector<FreeSpaceCheck> CheckFreeSpace(const PointCloud& source, const PointCloud& target,
                                           const ViewGrid& target_grid,
                                           const std::vector<Rigid3d>& target_from_source,
                                           int samples, double tolerance_mm, uint64_t seed) {
  if (target_grid.slot_of_point.size() != target.size()) {
    throw Error(util::StrCat("CheckFreeSpace: the target grid lists ",
                             target_grid.slot_of_point.size(), " points, the cloud has ",
                             target.size()));
  }
  std::vector<FreeSpaceCheck> out(target_from_source.size());
  const GridProjection& proj = target_grid.projection;
  if (!proj.fitted() || source.empty() || samples <= 0) return out;
  const int w = proj.width(), h = proj.height();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> depth(static_cast<size_t>(w) * h, nan);
  for (size_t i = 0; i < target.size(); ++i) {
    const uint32_t s = target_grid.slot_of_point[i];
    if (s >= depth.size()) {
      throw Error(util::StrCat("CheckFreeSpace: point ", i, " lies in slot ", s, " of a ", w, "x",
                               h, " grid"));
    }
    if (target.points[i].allFinite()) depth[s] = static_cast<float>(target.points[i].z());
  }
  // A seeded uniform sample (not normal-space: that favours the noisy edges).
  std::vector<uint32_t> pick;
  const size_t n = source.size();
  const size_t k = std::min<size_t>(n, static_cast<size_t>(samples));
  std::mt19937_64 rng(seed);
  if (k == n) {
    for (size_t i = 0; i < n; ++i) pick.push_back(static_cast<uint32_t>(i));
  } else {
    std::uniform_int_distribution<size_t> u(0, n - 1);
    for (size_t i = 0; i < k; ++i) pick.push_back(static_cast<uint32_t>(u(rng)));
  }
  for (size_t p = 0; p < target_from_source.size(); ++p) {
    const Rigid3d& t = target_from_source[p];
    std::vector<int8_t> state(pick.size(), 0);  // 0 no information, 1 seen, 2 in free space
    tbb::parallel_for(size_t{0}, pick.size(), [&](size_t s) {
      const Eigen::Vector3d& x = source.points[pick[s]];
      if (!x.allFinite()) return;
      const Eigen::Vector3d q = t * x;
      Eigen::Vector2f cr;
      if (!proj.Project(q.cast<float>(), &cr)) return;
      const int c = static_cast<int>(std::lround(cr.x())),
                r = static_cast<int>(std::lround(cr.y()));
      if (c < 0 || r < 0 || c >= w || r >= h) return;
      float zmin = std::numeric_limits<float>::infinity();
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int cc = c + dc, rr = r + dr;
          if (cc < 0 || rr < 0 || cc >= w || rr >= h) continue;
          const float z = depth[static_cast<size_t>(rr) * w + cc];
          if (!std::isnan(z)) zmin = std::min(zmin, z);
        }
      }
      if (!std::isfinite(zmin)) return;
      state[s] = q.z() < zmin - tolerance_mm ? 2 : 1;
    });
    for (int8_t x : state) {
      out[p].projected += x > 0;
      out[p].in_front += x == 2;
    }
  }
  return out;
}

}  // namespace fringe::registration
