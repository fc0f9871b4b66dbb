// Test-only helpers: simulated views of a scene reconstructed on the quarter-resolution rig
// (320x256 cameras), with the simulator's truth beside them. Markers are 10 mm across in these
// scenes so that on the small rig they are as many pixels wide as the demo's 5 mm markers on the
// full-resolution rig.
#pragma once

#include <vector>

#include "fringe/phase/pattern_scheme.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scene.h"
#include "fringe/stereo/camera_projector.h"
#include "fringe/stereo/reconstruct_view.h"

namespace fringe::registration::testing {

constexpr double kRigScale = 0.25;

inline StereoRig SmallRig() { return sim::ScaledRig(StereoRig::Reference(), kRigScale); }

struct SimulatedView {
  Rigid3d world_from_sensor;  // truth
  stereo::ViewReconstruction rec;
  // The left camera against the projector (when asked for): camera-projector mode.
  stereo::ViewReconstruction rec_camera_projector;
  std::vector<sim::MarkerObservation> truth_markers;
  cv::Mat truth_depth_left;  // CV_64F, left camera
};

inline SimulatedView SimulateView(const StereoRig& rig, const sim::Scene& scene,
                                  const Rigid3d& world_from_sensor, uint64_t view_index = 0,
                                  bool camera_projector = false) {
  const phase::PatternScheme scheme =
      phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  sim::RenderOptions options;
  options.projector.gamma = 1.0;  // gamma is the decoder's topic, not registration's
  const sim::Renderer renderer(scene, rig, options);
  const sim::ViewImages images =
      renderer.RenderView(world_from_sensor, phase::GeneratePatterns(scheme), view_index);
  SimulatedView v;
  v.world_from_sensor = world_from_sensor;
  v.rec = stereo::ReconstructView(rig, scheme, images.left.images, images.right.images);
  if (camera_projector) {
    v.rec_camera_projector = stereo::MakeCameraProjectorReconstructor(
                                 stereo::CameraProjectorRig::FromLeftCamera(rig), {scheme})
                                 .Reconstruct(images.left.images, {});
  }
  v.truth_markers = images.markers;
  v.truth_depth_left = images.left.truth.depth;
  return v;
}

// A 400 x 400 mm plane at z = 0 with a 60 mm box on it, and the given markers.
inline sim::Scene PlaneWithBox() {
  sim::Scene scene;
  sim::SceneObject plane;
  plane.name = "plane";
  plane.mesh = sim::MakeRectangleMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                      Eigen::Vector3d::UnitY(), 400, 400);
  plane.albedo = 0.6;
  scene.AddObject(plane);
  sim::SceneObject box;
  box.name = "box";
  box.mesh = sim::MakeBoxMesh({-30, -30, 0}, {30, 30, 25});
  box.albedo = 0.5;
  scene.AddObject(box);
  return scene;
}

inline sim::Marker MakeMarker(int id, const Eigen::Vector3d& centre,
                              const Eigen::Vector3d& normal = Eigen::Vector3d::UnitZ()) {
  sim::Marker m;
  m.id = id;
  m.centre_in_world = centre;
  m.normal_in_world = normal;
  m.inner_radius_mm = 3.0;
  m.outer_radius_mm = 5.0;
  return m;
}

}  // namespace fringe::registration::testing
