#include "fringe/sim/projector_board.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/json.h"
#include "fringe/phase/scheme_presets.h"
#include "fringe/sim/renderer.h"
#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe::sim {

void FringeBoardOptions::Check() const {
  board.Check();
  util::CheckOption(ambient >= 0, "FringeBoardOptions", "ambient", ambient, "must be >= 0");
  util::CheckOption(supersampling >= 1 && supersampling <= 8, "FringeBoardOptions", "supersampling",
                    supersampling, "must be in [1, 8]");
}

std::vector<cv::Mat> RenderBoardUnderPatterns(
    const CameraModel& camera, const CameraModel& projector, const Rigid3d& projector_from_camera,
    const CalibrationTarget& target, const Rigid3d& cam_from_board,
    const std::vector<cv::Mat>& patterns, const FringeBoardOptions& options, uint64_t stream) {
  options.Check();
  camera.Check();
  projector.Check();
  target.Check();
  const int W = camera.width, H = camera.height, n = options.supersampling, nn = n * n;
  const Eigen::Matrix3d R = cam_from_board.rotation_matrix();
  const Eigen::Vector3d t = cam_from_board.translation();
  const Eigen::Vector3d normal = R.col(2);
  const double plane_offset = normal.dot(t);
  // Per sample (row-major pixels, n x n samples each): albedo and projector pixel (NaN: unlit).
  const size_t count = static_cast<size_t>(W) * H * nn;
  std::vector<float> albedo(count), u(count), v(count);
  tbb::parallel_for(tbb::blocked_range<int>(0, H), [&](const tbb::blocked_range<int>& rr) {
    for (int r = rr.begin(); r < rr.end(); ++r) {
      Eigen::Vector2d guess = camera.Unproject(Eigen::Vector2d(0, r));
      for (int c = 0; c < W; ++c) {
        for (int s = 0; s < nn; ++s) {
          const size_t k = (static_cast<size_t>(r) * W + c) * nn + s;
          const Eigen::Vector2d px(c + (s % n + 0.5) / n - 0.5, r + (s / n + 0.5) / n - 0.5);
          const Eigen::Vector2d xy = UnprojectFrom(camera, px, guess, 2);
          if (s == 0) guess = xy;
          const Eigen::Vector3d d(xy.x(), xy.y(), 1.0);
          const double den = normal.dot(d);
          const double depth = std::abs(den) < 1e-12 ? -1 : plane_offset / den;
          u[k] = v[k] = std::nanf("");
          if (depth <= 0) {
            albedo[k] = static_cast<float>(options.board.background_albedo);
            continue;
          }
          const Eigen::Vector3d p_cam = depth * d;
          const Eigen::Vector3d p_board = R.transpose() * (p_cam - t);
          albedo[k] =
              static_cast<float>(BoardAlbedo(target, p_board.x(), p_board.y(), options.board));
          const Eigen::Vector3d p_proj = projector_from_camera * p_cam;
          if (p_proj.z() <= 0) continue;
          const Eigen::Vector2d q = projector.Project(p_proj);
          if (!projector.InImage(q)) continue;
          u[k] = static_cast<float>(q.x());
          v[k] = static_cast<float>(q.y());
        }
      }
    }
  });
  std::vector<cv::Mat> out;
  out.reserve(patterns.size());
  for (size_t p = 0; p < patterns.size(); ++p) {
    const cv::Mat& pat = patterns[p];
    if (pat.channels() != 1 || (pat.depth() != CV_8U && pat.depth() != CV_32F) ||
        pat.cols != projector.width || pat.rows != projector.height) {
      throw Error(util::StrCat("RenderBoardUnderPatterns: pattern ", p, " must be ",
                               projector.width, "x", projector.height,
                               " CV_8UC1 (0..255) or CV_32FC1 (0..1)"));
    }
    cv::Mat f, padded;
    pat.convertTo(f, CV_32F, pat.depth() == CV_8U ? 1.0 / 255.0 : 1.0);
    // One replicated pixel around, so that the bilinear lookup in the outer half pixel of the
    // projector image needs no branch.
    cv::copyMakeBorder(f, padded, 1, 1, 1, 1, cv::BORDER_REPLICATE);
    cv::Mat radiance(H, W, CV_32F);
    tbb::parallel_for(tbb::blocked_range<int>(0, H), [&](const tbb::blocked_range<int>& rr) {
      for (int r = rr.begin(); r < rr.end(); ++r) {
        for (int c = 0; c < W; ++c) {
          double acc = 0;
          for (int s = 0; s < nn; ++s) {
            const size_t k = (static_cast<size_t>(r) * W + c) * nn + s;
            double light = options.ambient;
            if (!std::isnan(u[k])) {
              const double x = u[k] + 1, y = v[k] + 1;  // padded coordinates
              const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
              const double a = x - x0, b = y - y0;
              const float* q0 = padded.ptr<float>(y0) + x0;
              const float* q1 = padded.ptr<float>(y0 + 1) + x0;
              const double top = q0[0] + a * (q0[1] - q0[0]);
              const double bottom = q1[0] + a * (q1[1] - q1[0]);
              light += options.board.illumination * (top + b * (bottom - top));
            }
            acc += albedo[k] * light;
          }
          radiance.at<float>(r, c) = static_cast<float>(acc / nn);
        }
      }
    });
    out.push_back(ApplySensor(radiance, options.board.sensor, util::MixSeed(stream, p)));
  }
  return out;
}

std::array<phase::PatternScheme, 2> BothDirectionSchemes(const CameraModel& projector,
                                                         const std::string& preset) {
  phase::SchemeParameters p;
  p.projector_width = projector.width;
  p.projector_height = projector.height;
  const phase::PatternScheme vertical = phase::MakePresetScheme(preset, p);
  p.horizontal = true;
  return {vertical, phase::MakePresetScheme(preset, p)};
}

std::array<phase::DecodeResult, 2> DecodeBoardUnderBothDirections(
    const CameraModel& camera, const CameraModel& projector, const Rigid3d& projector_from_camera,
    const CalibrationTarget& target, const Rigid3d& cam_from_board,
    const std::array<phase::PatternScheme, 2>& schemes, const FringeBoardOptions& options,
    uint64_t index) {
  phase::DecodeOptions d;
  d.projector_gamma = 1.0;  // the renderer's projector is linear
  std::array<phase::DecodeResult, 2> out;
  for (int k = 0; k < 2; ++k) {
    out[k] = phase::Decode(
        schemes[k],
        RenderBoardUnderPatterns(camera, projector, projector_from_camera, target, cam_from_board,
                                 phase::GeneratePatterns(schemes[k]), options, 2 * index + 100 + k),
        d);
  }
  return out;
}

void ProjectorCalibrationFolderOptions::Check() const {
  poses.Check();
  fringes.Check();
}

std::vector<Rigid3d> WriteProjectorCalibrationFolder(
    const StereoRig& rig, const CalibrationTarget& target, const std::filesystem::path& dir,
    const ProjectorCalibrationFolderOptions& options) {
  options.Check();
  rig.Check();
  target.Check();
  if (!rig.projector) throw Error("WriteProjectorCalibrationFolder: the rig has no projector");
  const CameraModel& proj = *rig.projector;
  const auto schemes = BothDirectionSchemes(proj, options.preset);
  BoardPoseOptions po = options.poses;
  po.both_cameras = options.two_cameras;
  const std::vector<Rigid3d> poses = GenerateBoardPoses(rig, target, po);
  std::filesystem::create_directories(dir);
  io::WriteJson(dir / "target.json", io::TargetToJson(target));
  const Rigid3d projector_from_right = rig.projector_from_left * rig.right_from_left.Inverse();
  for (size_t k = 0; k < poses.size(); ++k) {
    std::string name = std::to_string(k);
    name.insert(0, name.size() < 3 ? 3 - name.size() : 0, '0');  // 000, 001, ... (sorted)
    for (int cam = 0; cam < (options.two_cameras ? 2 : 1); ++cam) {
      const CameraModel& camera = cam == 0 ? rig.left : rig.right;
      const Rigid3d cam_from_board = cam == 0 ? poses[k] : rig.right_from_left * poses[k];
      const Rigid3d& projector_from_camera =
          cam == 0 ? rig.projector_from_left : projector_from_right;
      const std::filesystem::path pose_dir =
          options.two_cameras ? dir / name / (cam == 0 ? "left" : "right") : dir / name;
      const uint64_t offset = cam == 0 ? 0 : 1000;
      std::filesystem::create_directories(pose_dir);
      io::WriteImage(pose_dir / "board.png", RenderBoardImage(camera, target, cam_from_board,
                                                              options.fringes.board, offset + k)
                                                 .image);
      for (int d = 0; d < 2; ++d) {
        const std::filesystem::path stack = pose_dir / phase::DirectionName(schemes[d].direction);
        std::filesystem::create_directories(stack);
        const auto images = RenderBoardUnderPatterns(
            camera, proj, projector_from_camera, target, cam_from_board,
            phase::GeneratePatterns(schemes[d]), options.fringes, offset + 100 + 2 * k + d);
        const auto names = schemes[d].ImageNames();
        for (size_t i = 0; i < names.size(); ++i) io::WriteImage(stack / names[i], images[i]);
        phase::WriteScheme(stack / "manifest.json", schemes[d]);
      }
    }
  }
  return poses;
}

}  // namespace fringe::sim
