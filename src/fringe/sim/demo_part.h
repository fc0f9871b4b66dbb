// The built-in demo part: a machined-looking block generated in code (no data file), about
// 150 x 100 x 60 mm, on a base plate, carrying sticky markers.
//
// The part is a height field z = h(x, y) sampled on a grid_mm grid and triangulated (walls are
// one grid cell wide, i.e. vertical to within grid_mm). Features, in the part frame (world,
// z up, part centred at the origin, resting on the plate's top face z = 0):
//   - a rounded-rectangle footprint 150 x 100 mm (corner radius 10 mm);
//   - x < -20: three steps 20 / 28 / 36 mm high along y, a pocket 8 mm deep in the lowest step,
//     the word "FRINGE" engraved 0.3 mm deep (strokes ~0.8 mm wide) on the highest step;
//   - -20 <= x <= 40: a cylindrical crown (radius 60 mm, axis along y, 52..60 mm high) with a
//     bore of radius 8 mm down to z = 35;
//   - x > 40: a 20 mm deck with a round boss (r 9 mm, 45 mm high), a tube (r 6 mm, 38 mm high,
//     with a 3 mm bore down to 26 mm), fine ribs (0.6 mm wide, 0.5 mm high, 2 mm pitch) and a
//     45-degree chamfer along the outer edge.
// Objects: "part" (albedo 0.6), "base_plate" (albedo 0.45). Markers are placed with
// PlaceMarkers (markers.h) on the part's and plate's upward faces.
#pragma once

#include <cstdint>

#include "fringe/sim/scene.h"

namespace fringe::sim {

struct DemoPartOptions {
  double grid_mm = 0.2;                   // height-field grid spacing, [0.05, 2]
  bool engraving = true;                  // engraved text on the top step
  bool ribs = true;                       // fine ribs on the deck
  double plate_size_x_mm = 260;           // base plate, >= 160
  double plate_size_y_mm = 200;           // base plate, >= 110
  int markers_on_part = 16;               // >= 0
  int markers_on_plate = 24;              // >= 0
  double marker_outer_diameter_mm = 5.0;  // (0, 50]
  double marker_inner_diameter_mm = 3.0;  // (0, outer)
  uint64_t seed = 1;                      // marker placement

  void Check() const;
};

// Height of the part's top surface at (x, y) in mm, 0 outside its footprint (the analytic
// function the mesh samples).
double DemoPartHeight(double x_mm, double y_mm, const DemoPartOptions& options = {});

Scene MakeDemoPart(const DemoPartOptions& options = {});

}  // namespace fringe::sim
