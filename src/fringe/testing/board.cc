#include "fringe/testing/board.h"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

namespace fringe::calib::testing {

namespace {

// Reflectance in [0, 1] of the board at (x, y) mm; -1 outside the printed board.
double Reflectance(const CalibrationTarget& t, double x, double y) {
  Eigen::Vector2d lo, hi;
  t.Extent(&lo, &hi);
  if (x < lo.x() || y < lo.y() || x > hi.x() || y > hi.y()) return -1;
  if (t.type == TargetType::kChessboard) {
    const int i = static_cast<int>(std::floor(x / t.spacing_mm));
    const int j = static_cast<int>(std::floor(y / t.spacing_mm));
    if (i < -1 || j < -1 || i > t.cols - 1 || j > t.rows - 1) return 1;
    return ((i + j) & 1) ? 1 : 0;
  }
  const int row = static_cast<int>(std::lround(y / t.spacing_mm));
  if (row < 0 || row >= t.rows) return 1;
  double xs = x;
  if (t.type == TargetType::kAsymmetricCircleGrid && (row % 2 == 1)) xs -= 0.5 * t.spacing_mm;
  const int col = static_cast<int>(std::lround(xs / t.spacing_mm));
  if (col < 0 || col >= t.cols) return 1;
  const double r = std::hypot(xs - col * t.spacing_mm, y - row * t.spacing_mm);
  if (t.type == TargetType::kConcentricRings) {
    if (r <= t.outer_radius_mm && r >= t.inner_radius_mm) return 0;
    if (t.IsDistinct(row, col) && r <= t.dot_radius_mm) return 0;
    return 1;
  }
  return r <= t.outer_radius_mm ? 0 : 1;
}

}  // namespace

cv::Mat RenderTestBoard(const CalibrationTarget& target, const CameraModel& camera,
                        const Rigid3d& camera_from_board, const TestBoardOptions& options) {
  const Rigid3d board_from_camera = camera_from_board.Inverse();
  const Eigen::Matrix3d r = board_from_camera.rotation_matrix();
  const Eigen::Vector3d o = board_from_camera.translation();
  const int s = options.supersample;
  cv::Mat img(camera.height, camera.width, CV_32F);
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      double sum = 0;
      for (int sy = 0; sy < s; ++sy) {
        for (int sx = 0; sx < s; ++sx) {
          const Eigen::Vector2d px(u - 0.5 + (sx + 0.5) / s, v - 0.5 + (sy + 0.5) / s);
          const Eigen::Vector3d dir = r * camera.Ray(px);
          double value = options.background_dn;
          if (std::abs(dir.z()) > 1e-12) {
            const double lambda = -o.z() / dir.z();
            if (lambda > 0) {
              const Eigen::Vector3d q = o + lambda * dir;
              const double refl = Reflectance(target, q.x(), q.y());
              if (refl >= 0) value = options.dark_dn + refl * (options.bright_dn - options.dark_dn);
            }
          }
          sum += value;
        }
      }
      img.at<float>(v, u) = static_cast<float>(sum / (s * s));
    }
  }
  if (options.blur_sigma_px > 0) {
    cv::GaussianBlur(img, img, cv::Size(0, 0), options.blur_sigma_px, options.blur_sigma_px,
                     cv::BORDER_REPLICATE);
  }
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> noise(0.0, options.noise_sigma_dn);
  const bool wide = options.bit_depth == 16;
  cv::Mat out(img.size(), wide ? CV_16U : CV_8U);
  for (int v = 0; v < img.rows; ++v) {
    for (int u = 0; u < img.cols; ++u) {
      const double val = img.at<float>(v, u) + (options.noise_sigma_dn > 0 ? noise(rng) : 0.0);
      if (wide) {
        out.at<uint16_t>(v, u) = cv::saturate_cast<uint16_t>(std::lround(257 * val));
      } else {
        out.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(std::lround(val));
      }
    }
  }
  return out;
}

std::vector<Eigen::Vector2d> TrueCentres(const CalibrationTarget& target, const CameraModel& camera,
                                         const Rigid3d& camera_from_board) {
  std::vector<Eigen::Vector2d> out;
  for (const auto& c : target.FeatureCentres())
    out.push_back(camera.Project(camera_from_board * c));
  return out;
}

Rigid3d LookAtBoard(const CalibrationTarget& target, double distance_mm, double tilt_deg,
                    double azimuth_deg, double roll_deg, const Eigen::Vector2d& offset_mm) {
  Eigen::Vector2d lo, hi;
  target.Extent(&lo, &hi);
  Eigen::Vector3d mid(0.5 * (target.cols - 1) * target.spacing_mm,
                      0.5 * (target.rows - 1) * target.spacing_mm, 0);
  mid.head<2>() += offset_mm;
  const double az = azimuth_deg * M_PI / 180;
  const Eigen::Vector3d axis(std::cos(az), std::sin(az), 0);
  // Board frame: board normal (-z) faces the camera; camera z along board +z when untilted.
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(tilt_deg * M_PI / 180, axis).toRotationMatrix();
  const Eigen::Matrix3d roll =
      Eigen::AngleAxisd(roll_deg * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d cam_r_board = roll * tilt.transpose();
  const Eigen::Vector3d t = Eigen::Vector3d(0, 0, distance_mm) - cam_r_board * mid;
  return Rigid3d(cam_r_board, t);
}

}  // namespace fringe::calib::testing
