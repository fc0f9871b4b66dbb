// Camera + projector: the projector as an inverse camera, triangulated against one camera.
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
#include <memory>
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

// True when `scheme` was made for `projector`'s size: its absolute phase is a coordinate of this
// projector only then (a scheme for another projector decodes to wrong points, not missing ones).
bool SchemeFitsProjector(const phase::PatternScheme& scheme, const CameraModel& projector);

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

// Camera-projector correspondence: decodes one camera's stacks (one scheme: vertical or
// horizontal fringes; two: one of each direction) and triangulates every valid pixel against
// the projector. `options` supplies the depth range (min_depth_mm, max_depth_mm) and, for two
// directions, the triangulation options and the reprojection-residual limit. The residual is,
// for one direction, the round trip into the projector (px); for two, the RMS reprojection
// residual over camera and projector. Throws fringe::Error for a bad rig or options.
std::shared_ptr<const Correspondence> MakeCameraProjectorCorrespondence(
    const CameraProjectorRig& rig, const MatchingOptions& options = {});

// The ViewReconstructor of a camera + projector (the correspondence above; outliers and normals
// as in stereo mode, outliers' footprints from the camera): Reconstruct({stacks}) with
// ViewStacks::left[i] the camera's images of schemes[i]. summary.decode_left is the first
// scheme's decoding, decode_right the second direction's when there is one.
ViewReconstructor MakeCameraProjectorReconstructor(const CameraProjectorRig& rig,
                                                   const std::vector<phase::PatternScheme>& schemes,
                                                   const ReconstructionOptions& options = {});

// Trinocular use of a stereo rig with a calibrated projector: stereo matching as
// MakeStereoCorrespondence, then every valid left pixel without a stereo point whose
// camera-projector point (left ray against the projector column) the right camera cannot see
// is added from the left camera + projector. "Cannot see": the point projects outside the
// right image, or onto a right pixel without a valid phase, or onto one whose decoded phase
// differs from the left's by more than max_projector_error_px (the right camera sees another
// surface there: the point is shadowed for it). Left pixels the right camera does see but
// stereo rejected stay rejected (stereo had a reason). Points seen only by the right camera
// have no place on the left grid and are not added. summary.matching.projector_filled counts
// the added points. Throws fringe::Error for a rig without a projector, bad rig or options.
std::shared_ptr<const Correspondence> MakeTrinocularCorrespondence(
    const StereoRig& rig, const MatchingOptions& options = {});

}  // namespace fringe::stereo
