// Test views for fusion and meshing (not part of the library API): the simulator's exact
// per-pixel ground truth of the left camera, with Gaussian depth noise along each pixel's ray,
// grid normals estimated from the noisy cloud, and a pose that may carry a registration error.
#pragma once

#include <random>
#include <string>

#include "fringe/fusion/fuse.h"
#include "fringe/geometry/normals.h"
#include "fringe/sim/renderer.h"
#include "fringe/util/random.h"

namespace fringe::fusion::testing {

// The left camera's truth at `world_from_sensor`, noise sigma_mm along the rays; the view's
// pose is world_from_sensor_used (the true pose, or a misregistered one).
inline FusionView TruthView(const sim::Renderer& renderer, const std::string& name,
                            const Rigid3d& world_from_sensor, const Rigid3d& world_from_sensor_used,
                            double sigma_mm, uint64_t seed) {
  const sim::ViewImages v = renderer.RenderView(world_from_sensor, {}, seed);
  const sim::CameraTruth& t = v.left.truth;
  FusionView out;
  out.name = name;
  out.world_from_sensor = world_from_sensor_used;
  OrganizedPointCloud& g = out.cloud;
  g = OrganizedPointCloud(t.depth.cols, t.depth.rows, false, true, true);
  std::mt19937_64 rng(util::MixSeed(seed, 7));
  std::normal_distribution<double> noise(0, sigma_mm);
  for (int r = 0; r < g.height; ++r) {
    for (int c = 0; c < g.width; ++c) {
      if (!t.valid.at<uint8_t>(r, c)) continue;
      const cv::Vec3d p = t.points.at<cv::Vec3d>(r, c);
      const Eigen::Vector3d p_in_sensor(p[0], p[1], p[2]);
      const size_t i = g.index(c, r);
      g.cloud.points[i] = p_in_sensor * (1 + noise(rng) / p_in_sensor.norm());
      g.cloud.quality[i] = 60.f;
      g.cloud.intensity[i] = 128.f;
      g.valid[i] = 1;
    }
  }
  EstimateGridNormals(&g);
  return out;
}

}  // namespace fringe::fusion::testing
