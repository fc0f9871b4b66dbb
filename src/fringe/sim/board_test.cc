#include "fringe/sim/board.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fringe/util/error.h"

namespace fringe::sim {
namespace {

CameraModel PinholeCamera() {
  CameraModel c;
  c.width = 320;
  c.height = 256;
  c.fx = c.fy = 625;
  c.cx = 159.5;
  c.cy = 127.5;
  return c;
}

BoardRenderOptions NoiseFree() {
  BoardRenderOptions o;
  o.sensor.noise = false;
  o.sensor.float_output = true;
  return o;
}

// Intensity-weighted centroid of the darkness (white level - image) over the pixels whose ray
// meets the board (undistorted camera) within window_mm of the feature centre.
Eigen::Vector2d DarkCentroid(const cv::Mat& image, const CameraModel& cam,
                             const Rigid3d& cam_from_board, const Eigen::Vector3d& centre,
                             double window_mm, double white_level) {
  const Eigen::Matrix3d R = cam_from_board.rotation_matrix();
  const Eigen::Vector3d t = cam_from_board.translation();
  double sw = 0, sx = 0, sy = 0;
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) {
      const Eigen::Vector3d d(cam.Unproject(Eigen::Vector2d(c, r)).x(),
                              cam.Unproject(Eigen::Vector2d(c, r)).y(), 1.0);
      const double s = R.col(2).dot(t) / R.col(2).dot(d);
      const Eigen::Vector3d p = R.transpose() * (s * d - t);
      if ((p - centre).norm() > window_mm) continue;
      const double w = std::max(0.0, white_level - image.at<float>(r, c));
      sw += w;
      sx += w * c;
      sy += w * r;
    }
  }
  return {sx / sw, sy / sw};
}

// Centre of the ellipse that a board circle projects to (undistorted camera): the image conic
// C' = H^-T C H^-1 with H = K [r1 r2 t].
Eigen::Vector2d EllipseCentre(const CameraModel& cam, const Rigid3d& cam_from_board,
                              const Eigen::Vector3d& centre, double radius) {
  const Eigen::Matrix3d R = cam_from_board.rotation_matrix();
  Eigen::Matrix3d H;
  H << R.col(0), R.col(1), cam_from_board.translation();
  H = cam.K() * H;
  Eigen::Matrix3d C;
  C << 1, 0, -centre.x(), 0, 1, -centre.y(), -centre.x(), -centre.y(),
      centre.head<2>().squaredNorm() - radius * radius;
  const Eigen::Matrix3d Hi = H.inverse();
  const Eigen::Matrix3d Ci = Hi.transpose() * C * Hi;
  return -Ci.topLeftCorner<2, 2>().inverse() * Ci.topRightCorner<2, 1>();
}

TEST(Board, OptionDefaultsPassCheck) {
  EXPECT_NO_THROW(BoardRenderOptions().Check());
  EXPECT_NO_THROW(BoardPoseOptions().Check());
  BoardPoseOptions bad;
  bad.max_tilt_deg = 89;
  EXPECT_THROW(bad.Check(), Error);
}

TEST(Board, AlbedoFollowsTheTargetGeometry) {
  const BoardRenderOptions o;
  CalibrationTarget rings;  // reference: distinct features (3,4), (3,5), (2,4)
  const double s = rings.spacing_mm;
  EXPECT_EQ(BoardAlbedo(rings, 4 * s, 3 * s, o), o.black_albedo);  // distinct: centre dot
  EXPECT_EQ(BoardAlbedo(rings, 0, 0, o), o.white_albedo);          // plain ring: white centre
  const double mid_ring = 0.5 * (rings.inner_radius_mm + rings.outer_radius_mm);
  EXPECT_EQ(BoardAlbedo(rings, mid_ring, 0, o), o.black_albedo);
  EXPECT_EQ(BoardAlbedo(rings, 0.5 * s, 0.5 * s, o), o.white_albedo);
  EXPECT_EQ(BoardAlbedo(rings, -100, 0, o), o.background_albedo);
  CalibrationTarget chess;
  chess.type = TargetType::kChessboard;
  const double q = 0.25 * chess.spacing_mm;
  // Around an inner corner the four squares alternate.
  EXPECT_NE(BoardAlbedo(chess, q, q, o), BoardAlbedo(chess, -q, q, o));
  EXPECT_EQ(BoardAlbedo(chess, q, q, o), BoardAlbedo(chess, -q, -q, o));
  CalibrationTarget asym;
  asym.type = TargetType::kAsymmetricCircleGrid;
  EXPECT_EQ(BoardAlbedo(asym, 0.5 * s, s, o), o.black_albedo);  // odd row shifted by s/2
  EXPECT_EQ(BoardAlbedo(asym, 0, s, o), o.white_albedo);
}

// Fronto-parallel board, undistorted camera: the intensity centroid of each anti-aliased circle
// is its true projected centre.
TEST(Board, FrontoParallelCentroidsMatchTrueCentres) {
  const CameraModel cam = PinholeCamera();
  CalibrationTarget target;
  target.type = TargetType::kCircleGrid;
  target.rows = 5;
  target.cols = 7;
  const Eigen::Vector3d mid(3 * target.spacing_mm, 2 * target.spacing_mm, 0);
  const Rigid3d cam_from_board(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.3, -0.2, 500) - mid);
  const BoardRenderOptions opt = NoiseFree();
  const BoardImage board = RenderBoardImage(cam, target, cam_from_board, opt);
  const double white = opt.sensor.exposure * 255 * opt.white_albedo;
  const double window_mm = 1.4 * target.outer_radius_mm;
  const auto centres = target.FeatureCentres();
  constexpr double kTolerancePx = 0.005;
  ASSERT_EQ(board.NumVisible(), target.NumFeatures());
  double max_err = 0;
  for (int i = 0; i < target.NumFeatures(); ++i) {
    const Eigen::Vector2d c =
        DarkCentroid(board.image, cam, cam_from_board, centres[i], window_mm, white);
    max_err = std::max(max_err, (c - board.centres_px[i]).norm());
  }
  RecordProperty("max_centroid_error_px", std::to_string(max_err));
  EXPECT_LT(max_err, kTolerancePx);
}

// Tilted board: the centroid is the projected ellipse's centre, which differs from the true
// centre by the perspective bias.
TEST(Board, TiltedCentroidsShowThePerspectiveBias) {
  const CameraModel cam = PinholeCamera();
  CalibrationTarget target;
  target.type = TargetType::kCircleGrid;
  target.rows = 4;
  target.cols = 5;
  const Eigen::Vector3d mid(2 * target.spacing_mm, 1.5 * target.spacing_mm, 0);
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(0.9, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Rigid3d cam_from_board(rot, Eigen::Vector3d(0, 0, 400) - rot * mid);
  const BoardRenderOptions opt = NoiseFree();
  const BoardImage board = RenderBoardImage(cam, target, cam_from_board, opt);
  const double white = opt.sensor.exposure * 255 * opt.white_albedo;
  const double window_mm = 1.4 * target.outer_radius_mm;
  constexpr double kTolerancePx = 0.01;
  double max_bias = 0;
  int checked = 0;
  const auto centres = target.FeatureCentres();
  for (int i = 0; i < target.NumFeatures(); ++i) {
    if (!board.visible[i]) continue;
    const Eigen::Vector2d ellipse =
        EllipseCentre(cam, cam_from_board, centres[i], target.outer_radius_mm);
    const Eigen::Vector2d c =
        DarkCentroid(board.image, cam, cam_from_board, centres[i], window_mm, white);
    EXPECT_LT((c - ellipse).norm(), kTolerancePx) << i;
    max_bias = std::max(max_bias, (ellipse - board.centres_px[i]).norm());
    ++checked;
  }
  RecordProperty("max_perspective_bias_px", std::to_string(max_bias));
  EXPECT_GT(checked, 10);
  EXPECT_GT(max_bias, 10 * kTolerancePx);  // the bias is real and resolved
}

TEST(Board, DistinctRingsHaveDarkCentres) {
  const StereoRig rig = ScaledRig(StereoRig::Reference(), 0.5);
  const CalibrationTarget target;
  BoardPoseOptions po;
  po.count = 3;
  po.min_visible_fraction = 1.0;
  const auto poses = GenerateBoardPoses(rig, target, po);
  const StereoBoardImages imgs = RenderStereoBoard(rig, target, poses[0], NoiseFree(), 0);
  for (const BoardImage* b : {&imgs.left, &imgs.right}) {
    ASSERT_EQ(b->NumVisible(), target.NumFeatures());
    for (int r = 0; r < target.rows; ++r) {
      for (int c = 0; c < target.cols; ++c) {
        const Eigen::Vector2d px = b->centres_px[r * target.cols + c];
        const float v = b->image.at<float>(static_cast<int>(std::lround(px.y())),
                                           static_cast<int>(std::lround(px.x())));
        if (target.IsDistinct(r, c)) {
          EXPECT_LT(v, 60.0f) << r << "," << c;
        } else {
          EXPECT_GT(v, 120.0f) << r << "," << c;
        }
      }
    }
  }
}

TEST(Board, PosesAreVariedCoverTheImageAndAreSeeded) {
  const StereoRig rig = StereoRig::Reference();
  const CalibrationTarget target;
  BoardPoseOptions opt;
  opt.count = 18;
  const auto poses = GenerateBoardPoses(rig, target, opt);
  ASSERT_EQ(poses.size(), 18u);
  bool cells[9] = {};
  double max_tilt = 0;
  int partial = 0;
  for (const Rigid3d& p : poses) {
    const auto vis_l = VisibleFeatures(rig.left, target, p);
    const auto vis_r = VisibleFeatures(rig.right, target, rig.right_from_left * p);
    const double fl = std::count(vis_l.begin(), vis_l.end(), 1) / double(vis_l.size());
    const double fr = std::count(vis_r.begin(), vis_r.end(), 1) / double(vis_r.size());
    EXPECT_GE(fl, opt.min_visible_fraction);
    EXPECT_GE(fr, opt.min_visible_fraction);
    if (fl < 1) ++partial;
    // Tilt: angle between the board normal and the optical axis.
    const Eigen::Vector3d n = p.rotation_matrix().col(2);
    max_tilt = std::max(max_tilt, std::acos(std::min(1.0, n.z())) * 180 / M_PI);
    Eigen::Vector2d lo, hi;
    target.Extent(&lo, &hi);
    const Eigen::Vector2d px =
        rig.left.Project(p * Eigen::Vector3d(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), 0));
    const int cx = std::clamp(static_cast<int>(3 * (px.x() + 0.5) / rig.left.width), 0, 2);
    const int cy = std::clamp(static_cast<int>(3 * (px.y() + 0.5) / rig.left.height), 0, 2);
    cells[cy * 3 + cx] = true;
  }
  for (int i = 0; i < 9; ++i) EXPECT_TRUE(cells[i]) << "image cell " << i << " not covered";
  EXPECT_GT(max_tilt, 35.0);
  EXPECT_LT(max_tilt, 60.0 + 20.0);  // tilt about the view ray; plus the ray's own angle
  EXPECT_GT(partial, 0);
  const auto again = GenerateBoardPoses(rig, target, opt);
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(poses[i].ToMatrix3x4(), again[i].ToMatrix3x4());
  }
}

}  // namespace
}  // namespace fringe::sim
