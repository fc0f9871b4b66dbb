#include "fringe/sim/demo_part.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "fringe/sim/markers.h"
#include "fringe/util/error.h"

namespace fringe::sim {

namespace {

constexpr double kHalfX = 75, kHalfY = 50, kCornerRadius = 10;

// Engraving raster: 0.05 mm per pixel over the top step's text area.
struct TextMask {
  static constexpr double kX0 = -72, kY1 = 47, kMmPerPx = 0.05;
  cv::Mat mask;  // CV_8U, row 0 at y = kY1 (text reads along +x seen from -y)

  TextMask() {
    mask = cv::Mat::zeros(static_cast<int>(27 / kMmPerPx), static_cast<int>(50 / kMmPerPx), CV_8U);
    // ~8 mm tall capitals, strokes ~0.8 mm.
    cv::putText(mask, "FRINGE",
                cv::Point(static_cast<int>(2 / kMmPerPx), static_cast<int>(16 / kMmPerPx)),
                cv::FONT_HERSHEY_SIMPLEX, 5.2, cv::Scalar(255), static_cast<int>(0.8 / kMmPerPx),
                cv::LINE_8);
  }
  bool At(double x, double y) const {
    const int c = static_cast<int>(std::floor((x - kX0) / kMmPerPx));
    const int r = static_cast<int>(std::floor((kY1 - y) / kMmPerPx));
    return r >= 0 && c >= 0 && r < mask.rows && c < mask.cols && mask.at<uint8_t>(r, c) != 0;
  }
};

const TextMask& Text() {
  static const TextMask mask;
  return mask;
}

bool InRoundedRect(double x, double y, double hx, double hy, double radius) {
  const double dx = std::abs(x) - (hx - radius), dy = std::abs(y) - (hy - radius);
  if (std::abs(x) > hx || std::abs(y) > hy) return false;
  if (dx > 0 && dy > 0) return dx * dx + dy * dy <= radius * radius;
  return true;
}

double Sq(double v) { return v * v; }

}  // namespace

void DemoPartOptions::Check() const {
  using util::CheckOption;
  CheckOption(grid_mm >= 0.05 && grid_mm <= 2, "DemoPartOptions", "grid_mm", grid_mm,
              "must be in [0.05, 2]");
  CheckOption(plate_size_x_mm >= 160, "DemoPartOptions", "plate_size_x_mm", plate_size_x_mm,
              "must be >= 160");
  CheckOption(plate_size_y_mm >= 110, "DemoPartOptions", "plate_size_y_mm", plate_size_y_mm,
              "must be >= 110");
  CheckOption(markers_on_part >= 0, "DemoPartOptions", "markers_on_part", markers_on_part,
              "must be >= 0");
  CheckOption(markers_on_plate >= 0, "DemoPartOptions", "markers_on_plate", markers_on_plate,
              "must be >= 0");
  CheckOption(marker_outer_diameter_mm > 0 && marker_outer_diameter_mm <= 50, "DemoPartOptions",
              "marker_outer_diameter_mm", marker_outer_diameter_mm, "must be in (0, 50]");
  CheckOption(marker_inner_diameter_mm > 0 && marker_inner_diameter_mm < marker_outer_diameter_mm,
              "DemoPartOptions", "marker_inner_diameter_mm", marker_inner_diameter_mm,
              "must be in (0, marker_outer_diameter_mm)");
}

double DemoPartHeight(double x, double y, const DemoPartOptions& opt) {
  if (!InRoundedRect(x, y, kHalfX, kHalfY, kCornerRadius)) return 0;
  if (x < -20) {
    // Steps along y, a pocket in the lowest, engraving on the highest.
    if (y < -15) {
      if (x > -68 && x < -52 && y > -42 && y < -24) return 12;
      return 20;
    }
    if (y < 15) return 28;
    if (opt.engraving && Text().At(x, y)) return 36 - 0.3;
    return 36;
  }
  if (x <= 40) {
    // Cylindrical crown with a bore.
    if (Sq(x - 10) + Sq(y - 20) < Sq(8)) return 35;
    return std::sqrt(Sq(60) - Sq(x - 10));
  }
  // Deck: boss, tube with bore, ribs, chamfer.
  if (Sq(x - 58) + Sq(y + 30) < Sq(9)) return 45;
  const double tube = Sq(x - 60) + Sq(y - 30);
  if (tube < Sq(3)) return 26;
  if (tube < Sq(6)) return 38;
  double h = 20;
  if (x > 70) h = 20 - (x - 70);  // 45-degree chamfer down to 15 mm at the edge
  if (opt.ribs && x > 44 && x < 68 && y > -16 && y < 16 && std::fmod(x - 44, 2.0) < 0.6) {
    h += 0.5;
  }
  return h;
}

Scene MakeDemoPart(const DemoPartOptions& opt) {
  opt.Check();
  const double g = opt.grid_mm;
  // One extra cell beyond the footprint so the outer walls come down to the plate.
  const int nx = static_cast<int>(std::ceil(2 * kHalfX / g)) + 3;
  const int ny = static_cast<int>(std::ceil(2 * kHalfY / g)) + 3;
  const double x0 = -kHalfX - g, y0 = -kHalfY - g;
  SceneObject part;
  part.name = "part";
  part.albedo = 0.6;
  part.mesh.vertices.reserve(static_cast<size_t>(nx) * ny);
  std::vector<double> h(static_cast<size_t>(nx) * ny);
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double x = x0 + i * g, y = y0 + j * g;
      h[static_cast<size_t>(j) * nx + i] = DemoPartHeight(x, y, opt);
      part.mesh.vertices.emplace_back(x, y, h[static_cast<size_t>(j) * nx + i]);
    }
  }
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const int a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
      // Cells entirely on the plate are left to the plate (no coincident faces).
      if (h[a] == 0 && h[b] == 0 && h[c] == 0 && h[d] == 0) continue;
      part.mesh.triangles.push_back({a, b, d});
      part.mesh.triangles.push_back({a, d, c});
    }
  }
  Scene scene;
  scene.AddObject(std::move(part));
  SceneObject plate;
  plate.name = "base_plate";
  plate.albedo = 0.45;
  plate.mesh = MakeBoxMesh(Eigen::Vector3d(-opt.plate_size_x_mm / 2, -opt.plate_size_y_mm / 2, -10),
                           Eigen::Vector3d(opt.plate_size_x_mm / 2, opt.plate_size_y_mm / 2, 0));
  scene.AddObject(std::move(plate));

  MarkerOptions mo;
  mo.outer_diameter_mm = opt.marker_outer_diameter_mm;
  mo.inner_diameter_mm = opt.marker_inner_diameter_mm;
  mo.seed = opt.seed;
  mo.count = opt.markers_on_part;
  mo.objects = {"part"};
  PlaceMarkers(&scene, mo);
  mo.seed = opt.seed + 1;
  mo.count = opt.markers_on_plate;
  mo.objects = {"base_plate"};
  PlaceMarkers(&scene, mo);
  return scene;
}

}  // namespace fringe::sim
