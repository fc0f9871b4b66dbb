#include "fringe/sim/markers.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "fringe/sim/ray_caster.h"
#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe::sim {

void MarkerOptions::Check() const {
  using util::CheckOption;
  CheckOption(count >= 0, "MarkerOptions", "count", count, "must be >= 0");
  CheckOption(outer_diameter_mm > 0 && outer_diameter_mm <= 50, "MarkerOptions",
              "outer_diameter_mm", outer_diameter_mm, "must be in (0, 50]");
  CheckOption(inner_diameter_mm > 0 && inner_diameter_mm < outer_diameter_mm, "MarkerOptions",
              "inner_diameter_mm", inner_diameter_mm, "must be in (0, outer_diameter_mm)");
  CheckOption(min_gap_mm >= 0, "MarkerOptions", "min_gap_mm", min_gap_mm, "must be >= 0");
  CheckOption(max_deviation_mm > 0, "MarkerOptions", "max_deviation_mm", max_deviation_mm,
              "must be > 0");
  CheckOption(max_tilt_deg >= 0 && max_tilt_deg < 90, "MarkerOptions", "max_tilt_deg", max_tilt_deg,
              "must be in [0, 90)");
  CheckOption(max_attempts >= 1, "MarkerOptions", "max_attempts", max_attempts, "must be >= 1");
}

int PlaceMarkers(Scene* scene, const MarkerOptions& opt) {
  opt.Check();
  if (opt.count == 0) return 0;
  for (const auto& name : opt.objects) {
    if (!scene->FindObject(name)) {
      throw Error(util::StrCat("PlaceMarkers: the scene has no object '", name, "'"));
    }
  }
  // Markers only change albedo: cast against the geometry alone.
  Scene geometry = *scene;
  geometry.ClearMarkers();
  const RayCaster caster(geometry);
  Eigen::Vector3d lo, hi;
  scene->Bounds(&lo, &hi);
  const double top = hi.z() + 10;
  const double outer = 0.5 * opt.outer_diameter_mm;
  const double min_tilt_cos = std::cos(opt.max_tilt_deg * 3.14159265358979323846 / 180);
  util::Rng rng(opt.seed);
  std::uniform_real_distribution<double> ux(lo.x(), hi.x()), uy(lo.y(), hi.y());
  int placed = 0;
  for (int attempt = 0; attempt < opt.max_attempts && placed < opt.count; ++attempt) {
    const double x = ux(rng), y = uy(rng);
    const auto hit = caster.Cast(Eigen::Vector3d(x, y, top), -Eigen::Vector3d::UnitZ());
    if (!hit) continue;
    const std::string& name = geometry.objects()[hit->object].name;
    if (!opt.objects.empty() &&
        std::find(opt.objects.begin(), opt.objects.end(), name) == opt.objects.end()) {
      continue;
    }
    Eigen::Vector3d n = hit->normal;
    if (n.z() < 0) n = -n;
    if (n.z() < min_tilt_cos) continue;
    const Eigen::Vector3d c = hit->point;
    bool free = true;
    for (const Marker& m : scene->markers()) {
      if ((m.centre_in_world - c).norm() < outer + m.outer_radius_mm + opt.min_gap_mm) {
        free = false;
        break;
      }
    }
    if (!free) continue;
    // Probe the sticker's footprint.
    const Eigen::Vector3d u =
        (std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY())
            .cross(n)
            .normalized();
    const Eigen::Vector3d v = n.cross(u);
    bool flat = true;
    const double radii[4] = {0.25 * outer, 0.5 * outer, 0.75 * outer, outer + 0.3};
    const int dirs[4] = {6, 12, 18, 24};
    for (int ring = 0; ring < 4 && flat; ++ring) {
      for (int k = 0; k < dirs[ring] && flat; ++k) {
        const double a = 2 * 3.14159265358979323846 * k / dirs[ring];
        const Eigen::Vector3d q = c + radii[ring] * (std::cos(a) * u + std::sin(a) * v);
        const auto probe = caster.Cast(q + 5.0 * n, -n);
        flat = probe && probe->object == hit->object &&
               std::abs((probe->point - c).dot(n)) <= opt.max_deviation_mm;
      }
    }
    if (!flat) continue;
    Marker m;
    m.id = static_cast<int>(scene->markers().size());
    m.centre_in_world = c;
    m.normal_in_world = n;
    m.outer_radius_mm = outer;
    m.inner_radius_mm = 0.5 * opt.inner_diameter_mm;
    scene->AddMarker(m);
    ++placed;
  }
  return placed;
}

}  // namespace fringe::sim
