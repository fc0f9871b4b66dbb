// TEST FIXTURE ONLY (linked into fringe_calib_tests, not into the library): analytic,
// supersampled images of a calibration target seen by a camera, with the true projected feature
// centres. It exists so the calib tests do not depend on the simulator; the simulator
// (src/fringe/sim) is the project's renderer.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "fringe/geometry/calibration_target.h"
#include "fringe/geometry/camera.h"
#include "fringe/geometry/rigid3.h"

namespace fringe::calib::testing {

struct TestBoardOptions {
  int supersample = 4;          // samples per pixel side
  double blur_sigma_px = 0.7;   // Gaussian optical blur, px
  double noise_sigma_dn = 1.0;  // additive Gaussian noise, DN
  double dark_dn = 40;          // printed dark features
  double bright_dn = 210;       // white board
  double background_dn = 90;    // outside the board
  uint64_t seed = 1;
  // 8: CV_8U; 16: CV_16U holding the same noisy values times 257 (full 16-bit scale), rounded
  // there, so the two differ only in quantisation.
  int bit_depth = 8;
};

// 8- or 16-bit image of `target` at camera_from_board (DN on the 8-bit scale above).
cv::Mat RenderTestBoard(const CalibrationTarget& target, const CameraModel& camera,
                        const Rigid3d& camera_from_board, const TestBoardOptions& options = {});

// True projected feature centres (row-major), and whether each is in the image.
std::vector<Eigen::Vector2d> TrueCentres(const CalibrationTarget& target, const CameraModel& camera,
                                         const Rigid3d& camera_from_board);

// A board pose looking at the board centre from `distance_mm`, tilted by tilt_deg about an
// axis in the board plane at azimuth_deg, rotated in-plane by roll_deg.
Rigid3d LookAtBoard(const CalibrationTarget& target, double distance_mm, double tilt_deg,
                    double azimuth_deg, double roll_deg, const Eigen::Vector2d& offset_mm = {0, 0});

}  // namespace fringe::calib::testing
