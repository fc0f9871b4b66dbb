// Sticky markers measured in one view of the stereo sensor (thesis capability 3, first step).
//
// A marker is a white disk inside a black ring stuck on the part (sim/scene.h). In each camera's
// decoded background (texture) image the rings are found by calib::DetectRings: the same blob
// search, subpixel edges, ellipse fits and pole-polar centres as the ring calibration board, so
// the image centre is the true projection of the marker centre (exact for a planar ring under
// any perspective; markers conform to gently curved surfaces, where it stays close).
//
// Left/right matching (the thesis' depth-difference test): every right ring within
// max_epipolar_px of a left ring's epipolar line is a candidate; each candidate is triangulated
// and its depth along the left viewing ray compared with the phase-measured surface there (a
// plane fitted to the view's cloud around the marker: markers lie on the surface). The candidate
// that agrees best, within max_depth_difference_mm, wins; a right ring claimed by two left rings
// goes to the better one. This resolves several markers near one epipolar line, where the
// epipolar constraint alone cannot.
//
// Per marker: centre (triangulated), the surface normal there (the fitted plane, toward the
// sensor), the image centres, the outer radius in mm (from the ellipse and the depth) and the
// centre's 1-sigma uncertainty propagated from the ellipse fits through the triangulation.
//
// Frames and units: sensor frame = left camera frame, millimetres; pixels as conventions.md.
// Thread safety: free functions without shared state. Deterministic.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/calib/detect.h"
#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/stereo_rig.h"

namespace fringe::registration {

struct MarkerDetectionOptions {
  calib::DetectionOptions rings;      // ring search in each image (calib/detect.h)
  double inner_to_outer_ratio = 0.6;  // white disk radius / black ring outer radius, (0, 1)
  double max_epipolar_px = 2.0;       // distance of the right centre to the epipolar line, > 0
  // Triangulated depth vs the surface along the left ray: absolute part (mm, > 0) plus a part
  // proportional to the depth (>= 0).
  double max_depth_difference_mm = 1.0;
  double relative_depth_difference = 0.002;
  // Accepted outer radius in 3D (rejects board rings and other dark rings of the wrong size), mm.
  double min_outer_radius_mm = 1.0;  // > 0
  double max_outer_radius_mm = 6.0;  // > min_outer_radius_mm (board rings are 8)
  // Surface plane fitted to the cloud within this many outer radii of the marker centre, > 1.
  double surface_radius_factor = 2.0;
  int min_surface_points = 8;  // fewer: the marker is rejected (no surface to check), >= 3

  void Check() const;
};

// One marker measured in one view.
struct ViewMarker {
  int id = 0;                                                   // index in the view's list
  Eigen::Vector3d centre_in_sensor = Eigen::Vector3d::Zero();   // on the surface, mm
  Eigen::Vector3d normal_in_sensor = Eigen::Vector3d::UnitZ();  // unit, toward the sensor
  Eigen::Vector2d left_px = Eigen::Vector2d::Zero();            // projected centre, left image
  Eigen::Vector2d right_px = Eigen::Vector2d::Zero();           // projected centre, right image
  double outer_radius_mm = 0;                                   // black ring's outer radius
  double sigma_mm = 0;             // 1-sigma centre uncertainty: sqrt(trace of its 3x3 covariance)
  double depth_difference_mm = 0;  // triangulated minus surface depth along the left ray
  // The centre's covariance, sensor frame, mm^2; zero when unknown (a file without it). Stereo
  // triangulation is several times less certain along the viewing ray than across it (on the
  // simulated demo scan 0.0155 vs 0.0057 mm RMS), so the registration weights with the matrix.
  Eigen::Matrix3d covariance_mm2 = Eigen::Matrix3d::Zero();
};

// The centre's covariance: covariance_mm2, or sigma_mm^2 / 3 in every direction when it is
// unknown (zero); sigma_mm below min_sigma_mm is raised to it (a zero sigma would weigh a
// sighting infinitely).
Eigen::Matrix3d CentreCovariance(const ViewMarker& m, double min_sigma_mm = 1e-3);

// Why a ring seen in the left image did not become a marker.
struct RejectedMarker {
  Eigen::Vector2d left_px = Eigen::Vector2d::Zero();
  std::string reason;
};

enum class MarkerDetectionStatus { kOk, kNoMarkers };
const char* ToString(MarkerDetectionStatus s);

struct MarkerDetectionSummary {
  MarkerDetectionStatus status = MarkerDetectionStatus::kNoMarkers;
  std::string message;
  int rings_left = 0, rings_right = 0;  // rings found in each image
  int markers = 0;                      // matched, triangulated and on the surface
  int ambiguous_resolved = 0;  // markers with > 1 epipolar candidate settled by the depth test
  std::vector<RejectedMarker> rejected;
  double seconds = 0;
  bool ok() const { return status == MarkerDetectionStatus::kOk; }
  std::string BriefReport() const;
};

struct ViewMarkers {
  std::vector<ViewMarker> markers;
  MarkerDetectionSummary summary;
};

// Markers of one view. texture_left / texture_right: the cameras' decoded background images
// (CV_8U, or CV_32F on the 0-255 scale as stereo::ViewReconstruction holds them); cloud: the
// view's organized cloud on the left grid, left camera frame. Throws fringe::Error for bad options
// or images whose sizes disagree with the rig.
ViewMarkers DetectViewMarkers(const StereoRig& rig, const cv::Mat& texture_left,
                              const cv::Mat& texture_right, const OrganizedPointCloud& cloud,
                              const MarkerDetectionOptions& options = {});

// Markers of a one-camera view (camera + projector, stereo/camera_projector.h): each ring's
// image centre is the projection of the marker centre, so the centre is where the camera ray
// through it meets the measured surface (the plane fitted to the cloud around the ring, as the
// stereo depth test uses). Same output as DetectViewMarkers, with right_px = (NaN, NaN)
// written as null (no second image), depth_difference_mm = 0 (the centre is on the surface by
// construction) and sigma_mm from the ring centre's uncertainty along the ray's intersection
// with the plane plus the plane's own fit residual (its standard error at the centre).
// texture: the camera's decoded background; cloud on the camera grid, camera frame.
ViewMarkers DetectViewMarkersOneCamera(const CameraModel& camera, const cv::Mat& texture,
                                       const OrganizedPointCloud& cloud,
                                       const MarkerDetectionOptions& options = {});

// Distance of right_px to the epipolar line of left_px in the right image, pixels (the rig's
// lens distortion removed).
double EpipolarDistancePx(const StereoRig& rig, const Eigen::Vector2d& left_px,
                          const Eigen::Vector2d& right_px);
// (The signed distance: SignedEpipolarDistancePx, geometry/stereo_rig.h.)

// ---- Files (docs/formats.md, "View markers") ----

// OUT.markers.json beside a view's cloud: {"format": "fringe-view-markers", "version": 1,
// "frame": "sensor (left camera), mm", "markers": [{"id", "centre_in_sensor", "normal_in_sensor",
// "left_px", "right_px", "outer_radius_mm", "sigma_mm", "depth_difference_mm",
// "covariance_mm2": [xx, xy, xz, yy, yz, zz] (optional on reading)}]}. Atomic.
void WriteViewMarkers(const std::filesystem::path& path, const std::vector<ViewMarker>& markers);
// Reads it back; throws fringe::Error naming the file and field for anything malformed (wrong
// format, non-finite numbers, non-unit normals, negative sigma, more markers than the bound).
std::vector<ViewMarker> ReadViewMarkers(const std::filesystem::path& path);
// The same from a parsed document; `context` (the file name) starts every error message.
std::vector<ViewMarker> ViewMarkersFromJson(const nlohmann::json& j, const std::string& context);

// The path of the markers file beside a cloud: view.ply -> view.markers.json.
std::filesystem::path MarkersPathForCloud(const std::filesystem::path& cloud_path);

}  // namespace fringe::registration
