// Seeded placement of sticky markers on a scene's surfaces.
//
// A candidate centre is found by casting a ray straight down (world -z) at a random (x, y);
// it is kept when the surface there faces up within max_tilt_deg, the surface stays within
// max_deviation_mm of the candidate's tangent plane over the whole sticker (probed by rays on
// four rings out to the outer radius + 0.3 mm: steps, holes, ribs and engraving are avoided,
// gentle curvature is allowed since stickers conform), the probes hit the same object, and the
// ring keeps min_gap_mm from every other marker. Ground truth: the centre (on the surface) and
// the surface normal there.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fringe/sim/scene.h"

namespace fringe::sim {

struct MarkerOptions {
  int count = 20;                    // markers to place, >= 0
  double outer_diameter_mm = 5.0;    // black ring outer diameter, (0, 50]
  double inner_diameter_mm = 3.0;    // white disk diameter, (0, outer_diameter_mm)
  double min_gap_mm = 1.0;           // between neighbouring rings, >= 0
  double max_deviation_mm = 0.08;    // surface vs tangent plane over the sticker, > 0
  double max_tilt_deg = 60;          // surface normal vs world +z, [0, 90)
  std::vector<std::string> objects;  // only on these objects (by name); empty: any
  uint64_t seed = 1;
  int max_attempts = 20000;  // candidates tried before giving up, >= 1

  void Check() const;
};

// Appends up to options.count markers to the scene (ids continue the scene's list) and returns
// how many were placed (fewer when the free surface runs out).
int PlaceMarkers(Scene* scene, const MarkerOptions& options);

}  // namespace fringe::sim
