// The simulate-and-reconstruct setup shared by the multi-view benchmarks (bench_registration and
// bench_fusion repeat it today; this is the one to adopt): the demo part seen from `views` orbit
// views by the reference rig scaled by rig_scale, camera read noise noise_dn, no calibration
// images and no truth maps (the view poses are the truth), every view reconstructed with the
// true rig. Deterministic for a seed (sim/scan.h); Reconstruct may run concurrently.
//
//   bench::SimulatedScanOptions options;
//   options.views = views_n;
//   const bench::SimulatedScan scan(options);
//   sim::ViewImages images;
//   stereo::ViewReconstruction rec = scan.Reconstruct(v, &images);
//   ... scan.simulator().view_poses()[v], scan.simulator().scene().CombinedMesh() ...
#pragma once

#include <cstdint>
#include <utility>

#include "fringe/geometry/stereo_rig.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scan.h"
#include "fringe/stereo/reconstruct_view.h"

namespace fringe::bench {

struct SimulatedScanOptions {
  int views = 8;           // orbit views of the demo part, >= 1
  double rig_scale = 1.0;  // camera/projector resolution scale (1: 1280x1024 cameras)
  double noise_dn = 1.5;   // camera read noise, DN
  uint64_t seed = 1;       // scene markers, poses, noise
  stereo::ReconstructionOptions reconstruction;  // per view
};

class SimulatedScan {
 public:
  explicit SimulatedScan(const SimulatedScanOptions& options)
      : rig_(options.rig_scale == 1 ? StereoRig::Reference()
                                    : sim::ScaledRig(StereoRig::Reference(), options.rig_scale)),
        simulator_(rig_, ScanOptionsFor(options)),
        reconstructor_(rig_, simulator_.scheme(), options.reconstruction) {}

  const StereoRig& rig() const { return rig_; }
  const sim::ScanSimulator& simulator() const { return simulator_; }
  const stereo::ViewReconstructor& reconstructor() const { return reconstructor_; }

  // Renders view v (in [0, views)) and reconstructs it; `images` (optional) receives the rendered
  // view (textures, marker truth).
  stereo::ViewReconstruction Reconstruct(int v, sim::ViewImages* images = nullptr) const {
    sim::ViewImages rendered = simulator_.RenderView(v);
    stereo::ViewReconstruction rec =
        reconstructor_.Reconstruct(rendered.left.images, rendered.right.images);
    if (images) *images = std::move(rendered);
    return rec;
  }

 private:
  static sim::ScanOptions ScanOptionsFor(const SimulatedScanOptions& options) {
    sim::ScanOptions scan;
    scan.scene = "demo";
    scan.views = options.views;
    scan.seed = options.seed;
    scan.calibration_images = 0;
    scan.truth_maps = false;
    scan.render.sensor.read_noise_dn = options.noise_dn;
    return scan;
  }

  StereoRig rig_;
  sim::ScanSimulator simulator_;
  stereo::ViewReconstructor reconstructor_;
};

}  // namespace fringe::bench
