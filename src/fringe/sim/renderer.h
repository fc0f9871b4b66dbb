// The virtual scanner's image formation: Embree ray casting of a Scene seen by the two cameras
// of a StereoRig while its projector casts arbitrary images.
//
// Model (per camera sample ray, supersampled on an n x n grid inside each pixel and averaged —
// a box filter over the pixel footprint):
//   radiance = albedo * (ambient + brightness * P(u, v) * cos(theta) * lit)
//   P(u, v)  = black_level + (1 - black_level) * pattern(u, v)^gamma
// where (u, v) is the continuous projector pixel the surface point projects to (projector model
// = CameraModel with distortion), pattern() the projected image bilinearly interpolated (a
// slightly defocused projector; optional Gaussian projector defocus on top), theta the angle
// between the surface normal and the direction to the projector centre, and lit = 0 in
// projector shadow (a shadow ray toward the projector centre hits something) or outside the
// projector image. Then the sensor: optional Gaussian defocus, DN = exposure * full_scale *
// radiance, Gaussian read noise, optional shot noise, rounding, saturation at 2^bits - 1.
//
// Ray casting happens once per view, camera and sample: each row of samples is cast, the
// per-sample (albedo, cos * lit, projector coordinate) are cached, and every pattern is shaded
// from that cache. Hit points are refined in double precision (triangle plane, or the exact
// sphere of sphere objects) so ground truth is exact.
//
// Frames: world (the scene's), sensor = left camera; world_from_sensor places the rig.
// Noise is seeded per (seed, view, camera, pattern, row) with util::MixSeed: results do not
// depend on the thread count. Thread safety: a Renderer is immutable after construction; its
// const methods may run concurrently (they use TBB internally).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "fringe/geometry/camera.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/sim/ray_caster.h"
#include "fringe/sim/scene.h"

namespace fringe::sim {

// The camera sensor (shared by fringe and board rendering).
struct SensorOptions {
  int supersampling = 3;         // n: n x n samples per pixel, [1, 16]
  double exposure = 1.0;         // fraction of full scale for albedo 1 at radiance 1, (0, 100]
  int bit_depth = 8;             // 8 (CV_8U) or 12 (CV_16U, 0..4095)
  bool noise = true;             // false: noise-free (rounded and saturated only)
  double read_noise_dn = 1.5;    // Gaussian read noise sigma in DN of bit_depth, >= 0
  bool shot_noise = false;       // add photon (Poisson, Gaussian approx.) noise
  double electrons_per_dn = 40;  // conversion gain for shot noise, > 0
  double defocus_sigma_px = 0;   // Gaussian camera defocus sigma in pixels, >= 0 (0: none)
  bool float_output = false;     // true: return CV_32F DN before rounding/saturation (tests)
  uint64_t seed = 1;             // noise seed

  void Check() const;
  int FullScale() const { return (1 << bit_depth) - 1; }
};

struct ProjectorOptions {
  double gamma = 2.2;           // projector response exponent, (0, 10]
  double black_level = 0.01;    // light at pattern value 0, fraction of white, [0, 1)
  double brightness = 1.0;      // radiance of a white projector pixel at normal incidence, >= 0
  double ambient = 0.05;        // ambient radiance (fraction of white projector), >= 0
  double defocus_sigma_px = 0;  // Gaussian projector defocus in projector pixels, >= 0
  bool pixelated = false;       // true: nearest projector pixel instead of bilinear

  void Check() const;
};

struct RenderOptions {
  SensorOptions sensor;
  ProjectorOptions projector;
  bool truth = true;                             // compute ground-truth maps
  double shadow_offset_mm = 2e-3;                // shadow-ray start offset along the normal, > 0
  double marker_visibility_tolerance_mm = 0.05;  // marker centre vs first hit, > 0

  void Check() const;
};

// Per-pixel ground truth of one camera, from the ray through each pixel centre. Points and
// normals are in that camera's frame. Double precision in memory (files store float32).
struct CameraTruth {
  cv::Mat depth;      // CV_64F, z of the hit in the camera frame (mm); NaN where no hit
  cv::Mat points;     // CV_64FC3 hit point (mm, camera frame); NaN where no hit
  cv::Mat normals;    // CV_64FC3 unit normal (camera frame, toward the camera); NaN where no hit
  cv::Mat projector;  // CV_64FC2 continuous projector pixel (x, y); NaN where behind projector
  cv::Mat valid;      // CV_8U 255 where hit, lit by the projector and inside its image
  cv::Mat object_id;  // CV_32S index of the scene object hit, -1 where none
};

struct CameraImages {
  std::vector<cv::Mat> images;  // one per pattern: CV_8U / CV_16U (or CV_32F, float_output)
  CameraTruth truth;            // empty Mats when RenderOptions::truth is false
};

// A marker as seen in one view.
using MarkerObservation = scan::MarkerObservation;  // scan/truth.h

struct ViewImages {
  Rigid3d world_from_sensor;
  CameraImages left;
  CameraImages right;
  std::vector<MarkerObservation> markers;
};

class Renderer {
 public:
  // The scene is copied. Throws fringe::Error for bad options, a rig without a projector, or an
  // empty scene.
  Renderer(const Scene& scene, const StereoRig& rig, const RenderOptions& options = {});
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  const Scene& scene() const;
  const StereoRig& rig() const { return rig_; }
  const RenderOptions& options() const { return options_; }

  // Renders both cameras for every pattern (CV_8UC1 0..255 or CV_32FC1 0..1, projector size).
  // view_index only selects the noise stream. An empty pattern list renders truth only.
  ViewImages RenderView(const Rigid3d& world_from_sensor, const std::vector<cv::Mat>& patterns,
                        uint64_t view_index = 0) const;

  // One camera (camera index 0 = left, 1 = right selects the noise stream) at an arbitrary pose.
  CameraImages RenderCamera(const CameraModel& camera, const Rigid3d& world_from_camera,
                            const Rigid3d& world_from_projector,
                            const std::vector<cv::Mat>& patterns, uint64_t view_index,
                            int camera_index) const;

  // First hit along a ray from origin in unit direction dir (world frame), beyond t_min.
  std::optional<Hit> CastRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                             double t_min = 0) const;
  // Albedo at a hit, including markers.
  double AlbedoAt(const Hit& hit) const;

  // Markers' true image centres and visibility for a sensor pose.
  std::vector<MarkerObservation> ObserveMarkers(const Rigid3d& world_from_sensor) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  StereoRig rig_;
  RenderOptions options_;
};

// The sensor model applied to a noise-free radiance image (CV_32F, radiance units as above):
// defocus, exposure, noise, quantisation. `stream` selects the noise stream (rows get their own
// generator via MixSeed(stream, row)).
cv::Mat ApplySensor(const cv::Mat& radiance, const SensorOptions& options, uint64_t stream);

// The rig with every camera and the projector scaled in resolution and focal length by `scale`
// (same field of view, same geometry): e.g. 0.25 gives 320x256 cameras for fast tests.
StereoRig ScaledRig(const StereoRig& rig, double scale);

// Undistorted normalized coordinates of a pixel by Newton's method warm-started from `guess`
// (normalized coordinates of a nearby pixel). fixed_iterations = 0: iterate to convergence
// (1e-15), falling back to CameraModel::Unproject when that fails; > 0: exactly that many steps
// (2 suffice from a guess within a pixel, for sub-pixel samples in hot loops).
Eigen::Vector2d UnprojectFrom(const CameraModel& camera, const Eigen::Vector2d& pixel,
                              const Eigen::Vector2d& guess, int fixed_iterations = 0);

}  // namespace fringe::sim
