#include "fringe/sim/board.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr uint64_t kBoardStreamDomain = 0xB0A4D5EEDULL;

}  // namespace

void BoardRenderOptions::Check() const {
  using util::CheckOption;
  sensor.Check();
  CheckOption(edge_supersampling >= 1 && edge_supersampling <= 32, "BoardRenderOptions",
              "edge_supersampling", edge_supersampling, "must be in [1, 32]");
  for (auto [name, v] : {std::pair<const char*, double>{"white_albedo", white_albedo},
                         {"black_albedo", black_albedo},
                         {"background_albedo", background_albedo}}) {
    CheckOption(v >= 0 && v <= 1, "BoardRenderOptions", name, v, "must be in [0, 1]");
  }
  CheckOption(illumination >= 0, "BoardRenderOptions", "illumination", illumination,
              "must be >= 0");
}

void BoardPoseOptions::Check() const {
  using util::CheckOption;
  CheckOption(count >= 1, "BoardPoseOptions", "count", count, "must be >= 1");
  CheckOption(min_distance_mm > 0, "BoardPoseOptions", "min_distance_mm", min_distance_mm,
              "must be > 0");
  CheckOption(max_distance_mm >= min_distance_mm, "BoardPoseOptions", "max_distance_mm",
              max_distance_mm, "must be >= min_distance_mm");
  CheckOption(max_tilt_deg >= 0 && max_tilt_deg <= 85, "BoardPoseOptions", "max_tilt_deg",
              max_tilt_deg, "must be in [0, 85]");
  CheckOption(max_roll_deg >= 0 && max_roll_deg <= 180, "BoardPoseOptions", "max_roll_deg",
              max_roll_deg, "must be in [0, 180]");
  CheckOption(min_visible_fraction > 0 && min_visible_fraction <= 1, "BoardPoseOptions",
              "min_visible_fraction", min_visible_fraction, "must be in (0, 1]");
}

int BoardImage::NumVisible() const {
  return static_cast<int>(std::count(visible.begin(), visible.end(), 1));
}

double BoardAlbedo(const CalibrationTarget& target, double x, double y,
                   const BoardRenderOptions& o) {
  Eigen::Vector2d lo, hi;
  target.Extent(&lo, &hi);
  if (x < lo.x() || x > hi.x() || y < lo.y() || y > hi.y()) return o.background_albedo;
  const double s = target.spacing_mm;
  if (target.type == TargetType::kChessboard) {
    const long i = static_cast<long>(std::floor(x / s));
    const long j = static_cast<long>(std::floor(y / s));
    if (i < -1 || i > target.cols - 1 || j < -1 || j > target.rows - 1) return o.white_albedo;
    return ((i + j) % 2 + 2) % 2 == 0 ? o.black_albedo : o.white_albedo;
  }
  const int r = std::clamp(static_cast<int>(std::lround(y / s)), 0, target.rows - 1);
  const double offset =
      (target.type == TargetType::kAsymmetricCircleGrid && r % 2 == 1) ? 0.5 * s : 0.0;
  const int c = std::clamp(static_cast<int>(std::lround((x - offset) / s)), 0, target.cols - 1);
  const double d = std::hypot(x - (c * s + offset), y - r * s);
  if (target.type == TargetType::kConcentricRings) {
    if (d <= target.outer_radius_mm && d >= target.inner_radius_mm) return o.black_albedo;
    if (d <= target.dot_radius_mm && target.IsDistinct(r, c)) return o.black_albedo;
    return o.white_albedo;
  }
  return d <= target.outer_radius_mm ? o.black_albedo : o.white_albedo;
}

std::vector<uint8_t> VisibleFeatures(const CameraModel& camera, const CalibrationTarget& target,
                                     const Rigid3d& cam_from_board) {
  const Eigen::Matrix3d R = cam_from_board.rotation_matrix();
  const Eigen::Vector3d t = cam_from_board.translation();
  std::vector<Eigen::Vector2d> outline;
  if (target.type == TargetType::kChessboard) {
    const double h = 0.5 * target.spacing_mm;
    outline = {{-h, -h}, {0, -h}, {h, -h}, {h, 0}, {h, h}, {0, h}, {-h, h}, {-h, 0}};
  } else {
    for (int k = 0; k < 16; ++k) {
      const double a = 2 * kPi * k / 16;
      outline.emplace_back(target.outer_radius_mm * std::cos(a),
                           target.outer_radius_mm * std::sin(a));
    }
  }
  std::vector<uint8_t> visible;
  for (const Eigen::Vector3d& centre : target.FeatureCentres()) {
    const Eigen::Vector3d c_cam = R * centre + t;
    // The printed side (-z) faces the camera when the camera lies on the -z side of the board.
    bool ok = c_cam.z() > 0 && R.col(2).dot(c_cam) > 0;
    for (size_t k = 0; ok && k < outline.size(); ++k) {
      const Eigen::Vector3d p =
          R * (centre + Eigen::Vector3d(outline[k].x(), outline[k].y(), 0)) + t;
      ok = p.z() > 0 && camera.InImage(camera.Project(p), 1.0);
    }
    visible.push_back(ok ? 1 : 0);
  }
  return visible;
}

BoardImage RenderBoardImage(const CameraModel& camera, const CalibrationTarget& target,
                            const Rigid3d& cam_from_board, const BoardRenderOptions& options,
                            uint64_t stream) {
  options.Check();
  camera.Check();
  target.Check();
  const int W = camera.width, H = camera.height;
  const Eigen::Matrix3d R = cam_from_board.rotation_matrix();
  const Eigen::Vector3d t = cam_from_board.translation();
  const Eigen::Vector3d normal = R.col(2);
  const double plane_offset = normal.dot(t);
  // Albedo seen along the ray through a pixel position; updates the undistortion warm start.
  auto albedo_at = [&](double x, double y, Eigen::Vector2d* guess) {
    const Eigen::Vector2d xy = UnprojectFrom(camera, Eigen::Vector2d(x, y), *guess, 2);
    *guess = xy;
    const Eigen::Vector3d d(xy.x(), xy.y(), 1.0);
    const double den = normal.dot(d);
    if (std::abs(den) < 1e-12) return options.background_albedo;
    const double s = plane_offset / den;
    if (s <= 0) return options.background_albedo;
    const Eigen::Vector3d p_board = R.transpose() * (s * d - t);
    return BoardAlbedo(target, p_board.x(), p_board.y(), options);
  };

  // Albedo at every pixel corner, (H + 1) x (W + 1).
  std::vector<double> corners(static_cast<size_t>(H + 1) * (W + 1));
  tbb::parallel_for(tbb::blocked_range<int>(0, H + 1), [&](const tbb::blocked_range<int>& rr) {
    for (int r = rr.begin(); r < rr.end(); ++r) {
      Eigen::Vector2d guess = camera.Unproject(Eigen::Vector2d(-0.5, r - 0.5));
      for (int c = 0; c <= W; ++c) {
        corners[static_cast<size_t>(r) * (W + 1) + c] = albedo_at(c - 0.5, r - 0.5, &guess);
      }
    }
  });

  const int n = options.edge_supersampling;
  cv::Mat radiance(H, W, CV_32F);
  tbb::parallel_for(tbb::blocked_range<int>(0, H), [&](const tbb::blocked_range<int>& rr) {
    for (int r = rr.begin(); r < rr.end(); ++r) {
      Eigen::Vector2d guess = camera.Unproject(Eigen::Vector2d(0, r));
      float* dst = radiance.ptr<float>(r);
      for (int c = 0; c < W; ++c) {
        const double centre = albedo_at(c, r, &guess);
        const size_t k = static_cast<size_t>(r) * (W + 1) + c;
        double value = centre;
        if (corners[k] != centre || corners[k + 1] != centre || corners[k + W + 1] != centre ||
            corners[k + W + 2] != centre) {
          // An edge crosses the pixel: box filter by n x n samples.
          Eigen::Vector2d g = guess;
          double sum = 0;
          for (int j = 0; j < n; ++j) {
            for (int i = 0; i < n; ++i) {
              sum += albedo_at(c + (i + 0.5) / n - 0.5, r + (j + 0.5) / n - 0.5, &g);
            }
          }
          value = sum / (n * n);
        }
        dst[c] = static_cast<float>(value * options.illumination);
      }
    }
  });

  BoardImage out;
  out.cam_from_board = cam_from_board;
  out.image = ApplySensor(radiance, options.sensor,
                          util::MixSeed(options.sensor.seed ^ kBoardStreamDomain, stream));
  for (const Eigen::Vector3d& centre : target.FeatureCentres()) {
    const Eigen::Vector3d p = cam_from_board * centre;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    out.centres_px.push_back(p.z() > 0 ? camera.Project(p) : Eigen::Vector2d(nan, nan));
  }
  out.visible = VisibleFeatures(camera, target, cam_from_board);
  return out;
}

StereoBoardImages RenderStereoBoard(const StereoRig& rig, const CalibrationTarget& target,
                                    const Rigid3d& left_from_board,
                                    const BoardRenderOptions& options, uint64_t index) {
  StereoBoardImages out;
  out.left = RenderBoardImage(rig.left, target, left_from_board, options, 2 * index);
  out.right = RenderBoardImage(rig.right, target, rig.right_from_left * left_from_board, options,
                               2 * index + 1);
  return out;
}

std::vector<Rigid3d> GenerateBoardPoses(const StereoRig& rig, const CalibrationTarget& target,
                                        const BoardPoseOptions& options) {
  options.Check();
  target.Check();
  Eigen::Vector2d lo, hi;
  target.Extent(&lo, &hi);
  const Eigen::Vector3d board_mid(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), 0);
  const CameraModel& cam = rig.left;
  std::vector<Rigid3d> poses;
  for (int i = 0; i < options.count; ++i) {
    util::Rng rng(util::MixSeed(options.seed, static_cast<uint64_t>(i)));
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    // Image region: cells of a 3 x 3 grid in turn (the centre first), so that every part of the
    // image is covered.
    static constexpr int kCellOrder[9] = {4, 0, 8, 2, 6, 1, 7, 3, 5};
    const int cell = kCellOrder[i % 9];
    bool found = false;
    for (int attempt = 0; attempt < 2000 && !found; ++attempt) {
      // When strict visibility requirements keep failing, aim ever closer to the image centre
      // and farther away.
      const double relax = std::clamp((attempt - 300) / 1200.0, 0.0, 1.0);
      const double u0 = (cell % 3 + unit(rng)) / 3.0 * cam.width - 0.5;
      const double v0 = (cell / 3 + unit(rng)) / 3.0 * cam.height - 0.5;
      const double u = u0 + relax * (0.5 * cam.width - 0.5 - u0);
      const double v = v0 + relax * (0.5 * cam.height - 0.5 - v0);
      const double distance =
          options.min_distance_mm +
          (relax + (1 - relax) * unit(rng)) * (options.max_distance_mm - options.min_distance_mm);
      const double tilt = options.max_tilt_deg * kDeg * unit(rng);
      const double tilt_axis = 2 * kPi * unit(rng);
      const double roll = options.max_roll_deg * kDeg * (2 * unit(rng) - 1);
      const Eigen::Vector3d ray = cam.Ray(Eigen::Vector2d(u, v));
      // Facing the camera along the ray, board x roughly along image x.
      const Eigen::Vector3d z = ray;
      const Eigen::Vector3d x =
          (Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(z) * z).normalized();
      const Eigen::Vector3d y = z.cross(x);
      Eigen::Matrix3d base;
      base << x, y, z;
      const Eigen::Vector3d axis_in_board(std::cos(tilt_axis), std::sin(tilt_axis), 0);
      const Eigen::Matrix3d rot =
          base * Eigen::AngleAxisd(tilt, axis_in_board).toRotationMatrix() *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      const Rigid3d left_from_board(rot, distance * ray - rot * board_mid);
      auto fraction = [&](const CameraModel& c, const Rigid3d& cam_from_board) {
        const auto vis = VisibleFeatures(c, target, cam_from_board);
        return std::count(vis.begin(), vis.end(), 1) / static_cast<double>(vis.size());
      };
      if (fraction(rig.left, left_from_board) < options.min_visible_fraction) continue;
      if (options.both_cameras && fraction(rig.right, rig.right_from_left * left_from_board) <
                                      options.min_visible_fraction) {
        continue;
      }
      poses.push_back(left_from_board);
      found = true;
    }
    if (!found) {
      throw Error(
          util::StrCat("GenerateBoardPoses: no pose with ", options.min_visible_fraction,
                       " of the features visible found for pose ", i,
                       " (board too large for the field of view, or distances too short?)"));
    }
  }
  return poses;
}

}  // namespace fringe::sim
