// Camera + projector: the projector as an inverse camera, triangulated against one camera
// (issue 14).
//
// Correspondence: a camera pixel's decoded absolute phase is its projector coordinate along the
// fringe direction (phase/pattern_scheme.h): the column u for vertical fringes, the row v for
// horizontal ones, pixel centres at integers (the convention of geometry/camera.h).
//
// One direction: the point is where the camera ray meets the surface the projector maps onto
// that column (row). With lens distortion that surface is not a plane (a straight line in the
// projector image is not the image of a plane), so the intersection is solved exactly in the
// distorted model: the camera ray projects to a straight line in the projector's undistorted
// normalized plane (the epipolar line, normal n = c x w with c the camera centre and w the ray
// direction in the projector frame); along that line Newton's method finds the normalized point
// whose DISTORTED coordinate equals the decoded one (distortion is near the identity, so it
// converges in a few steps to 1e-15), and the ray depth follows in closed form. The returned
// residual is the round trip: |projector coordinate of the point - decoded coordinate| (px).
// The two views' viewing geometry limits the accuracy: a coordinate along the baseline
// (vertical fringes for a horizontal baseline) triangulates well, one across it does not
// (rejected as kParallelRays when the camera ray is within min_ray_angle_rad of the surface).
//
// Both directions: (u, v) is a projector pixel; the two rays are triangulated in the distorted
// models with stereo/triangulation.h (the projector as the second view).
//
// Frames: points in the CAMERA frame (mm); projector_from_camera maps camera to projector
// coordinates (OpenCV stereoCalibrate's R, T with the camera first).
//
// Thread safety: functions and const methods are reentrant; results do not depend on the
// number of threads.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "fringe/geometry/camera.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/stereo/reconstruct_view.h"
#include "fringe/stereo/triangulation.h"

namespace fringe::stereo {

// One camera and the calibrated projector.
struct CameraProjectorRig {
  CameraModel camera;
  CameraModel projector;
  Rigid3d projector_from_camera;

  // The left camera and the projector of a rig; throws fringe::Error when the rig has no
  // projector.
  static CameraProjectorRig FromLeftCamera(const StereoRig& rig);
  // Throws fringe::Error for an invalid model or a zero baseline.
  void Check() const;
  // The pair as a two-view rig (the projector as the right view) for stereo/triangulation.h.
  StereoRig AsTwoViewRig() const;
};

// One projector coordinate along `direction` (u for vertical fringes, v for horizontal ones).
TriangulatedPoint TriangulateCameraProjector(const CameraProjectorRig& rig,
                                             const Eigen::Vector2d& camera_px,
                                             double projector_coordinate_px,
                                             phase::FringeDirection direction,
                                             const TriangulationOptions& options = {});

// Same with the camera ray already known (unit, camera frame): the reconstructor caches them.
TriangulatedPoint TriangulateCameraProjectorRay(const CameraProjectorRig& rig,
                                                const Eigen::Vector3d& ray_in_camera,
                                                double projector_coordinate_px,
                                                phase::FringeDirection direction,
                                                const TriangulationOptions& options = {});

// Both projector coordinates (a projector pixel): two-ray triangulation in the distorted models.
TriangulatedPoint TriangulateCameraProjector(const CameraProjectorRig& rig,
                                             const Eigen::Vector2d& camera_px,
                                             const Eigen::Vector2d& projector_px,
                                             const TriangulationOptions& options = {});

struct CameraProjectorOptions {
  // Decoding, outliers and normals as in stereo mode (outliers.focal_px is taken from the
  // camera); `matching` supplies the depth range
  // (min_depth_mm, max_depth_mm) and, for two directions, the triangulation options and the
  // reprojection-residual limit.
  ReconstructionOptions reconstruction;
  void Check() const;
};

// Decodes one camera's stacks and triangulates every valid pixel against the projector.
// Output as ViewReconstructor's (reconstruct_view.h): an organized cloud on the CAMERA grid in
// the camera frame, the per-pixel residual (one direction: the round trip into the projector,
// px; two directions: the RMS reprojection residual over camera and projector), outliers and
// normals. summary.decode_left is the (first) camera stack's decoding, decode_right the second
// direction's when there is one.
class CameraProjectorReconstructor {
 public:
  // schemes: one (vertical or horizontal fringes) or two (one of each direction). Throws
  // fringe::Error for a bad rig, schemes or options.
  CameraProjectorReconstructor(const CameraProjectorRig& rig,
                               const std::vector<phase::PatternScheme>& schemes,
                               const CameraProjectorOptions& options = {});
  // stacks[i]: the camera's images for schemes[i], in the scheme's order, camera-sized.
  ViewReconstruction Reconstruct(const std::vector<std::vector<cv::Mat>>& stacks) const;

 private:
  CameraProjectorRig rig_;
  std::vector<phase::PatternScheme> schemes_;
  CameraProjectorOptions options_;
  std::vector<Eigen::Vector3d> rays_;  // unit camera rays per pixel (row-major)
};

}  // namespace fringe::stereo
