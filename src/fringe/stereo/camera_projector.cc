#include "fringe/stereo/camera_projector.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>

#include "fringe/phase/decode.h"
#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::stereo {
namespace {

constexpr int kMaxNewtonIterations = 30;

}  // namespace

bool SchemeFitsProjector(const phase::PatternScheme& scheme, const CameraModel& projector) {
  return scheme.projector_width == projector.width && scheme.projector_height == projector.height;
}

CameraProjectorRig CameraProjectorRig::FromLeftCamera(const StereoRig& rig) {
  if (!rig.projector) {
    throw Error("camera-projector: the rig has no calibrated projector");
  }
  CameraProjectorRig out;
  out.camera = rig.left;
  out.projector = *rig.projector;
  out.projector_from_camera = rig.projector_from_left;
  return out;
}

void CameraProjectorRig::Check() const {
  camera.Check();
  projector.Check();
  if (!(projector_from_camera.translation().norm() > 0)) {
    throw Error("camera-projector rig: zero baseline between camera and projector");
  }
}

StereoRig CameraProjectorRig::AsTwoViewRig() const {
  StereoRig two;
  two.left = camera;
  two.right = projector;
  two.right_from_left = projector_from_camera;
  return two;
}

TriangulatedPoint TriangulateCameraProjectorRay(const CameraProjectorRig& rig,
                                                const Eigen::Vector3d& ray_in_camera,
                                                double projector_coordinate_px,
                                                phase::FringeDirection direction,
                                                const TriangulationOptions& options) {
  TriangulatedPoint out;
  const CameraModel& proj = rig.projector;
  const bool vertical = direction == phase::FringeDirection::kVertical;
  // In the projector frame: the camera centre c and the ray direction w.
  const Eigen::Vector3d c = rig.projector_from_camera.translation();
  const Eigen::Vector3d w = rig.projector_from_camera.RotateDirection(ray_in_camera);
  // Epipolar line n . (x, y, 1) = 0 in the undistorted normalized projector plane.
  const Eigen::Vector3d n = c.cross(w);
  // Along the line, the free normalized coordinate is the one the fringes measure (x for
  // columns); the other follows: y = -(n0 x + n2) / n1 (or x from y for rows).
  const double n_free = vertical ? n.x() : n.y();
  const double n_dep = vertical ? n.y() : n.x();
  if (std::abs(n_dep) < 1e-12 * n.norm()) {
    out.status = TriangulationStatus::kParallelRays;  // line along the measured coordinate
    return out;
  }
  const double slope = -n_free / n_dep, offset = -n.z() / n_dep;
  const double target = vertical ? (projector_coordinate_px - proj.cx) / proj.fx
                                 : (projector_coordinate_px - proj.cy) / proj.fy;
  // Newton on the free coordinate t: distorted(t, slope t + offset)[measured] = target.
  double t = target;
  bool converged = false;
  for (int it = 0; it < kMaxNewtonIterations; ++it) {
    const double other = slope * t + offset;
    const Eigen::Vector2d xy = vertical ? Eigen::Vector2d(t, other) : Eigen::Vector2d(other, t);
    const Eigen::Vector2d xy_d = proj.Distort(xy);
    const Eigen::Matrix2d jac = proj.DistortJacobian(xy);
    const int k = vertical ? 0 : 1;
    const double g = xy_d[k] - target;
    const double dg = vertical ? jac(0, 0) + jac(0, 1) * slope : jac(1, 1) + jac(1, 0) * slope;
    if (!(std::abs(dg) > 1e-12)) break;
    const double step = g / dg;
    t -= step;
    if (!std::isfinite(t)) break;
    if (std::abs(step) < 1e-15 * (1 + std::abs(t))) {
      converged = true;
      break;
    }
  }
  if (!converged) {
    out.status = TriangulationStatus::kParallelRays;
    return out;
  }
  const Eigen::Vector2d xy =
      vertical ? Eigen::Vector2d(t, slope * t + offset) : Eigen::Vector2d(slope * t + offset, t);
  // The projector ray through xy and the camera ray must not be (nearly) parallel.
  const Eigen::Vector3d d_proj = Eigen::Vector3d(xy.x(), xy.y(), 1).normalized();
  const Eigen::Vector3d w_unit = w.normalized();
  if (d_proj.cross(w_unit).norm() < std::sin(options.min_ray_angle_rad)) {
    out.status = TriangulationStatus::kParallelRays;
    return out;
  }
  // Depth s along the camera ray: (c + s w) projects to xy. Of the two equations
  // c_x + s w_x = x (c_z + s w_z) and the same in y, take the better conditioned one.
  const double den_x = w.x() - xy.x() * w.z(), den_y = w.y() - xy.y() * w.z();
  const double s = std::abs(den_x) >= std::abs(den_y) ? (xy.x() * c.z() - c.x()) / den_x
                                                      : (xy.y() * c.z() - c.y()) / den_y;
  const Eigen::Vector3d p_in_proj = c + s * w;
  if (!(s > 0) || !(p_in_proj.z() > 0)) {
    out.status = TriangulationStatus::kBehindCamera;
    return out;
  }
  out.status = TriangulationStatus::kOk;
  out.p_in_left = s * ray_in_camera;
  const Eigen::Vector2d back = proj.Project(p_in_proj);
  out.reprojection_error_px = std::abs((vertical ? back.x() : back.y()) - projector_coordinate_px);
  return out;
}

TriangulatedPoint TriangulateCameraProjector(const CameraProjectorRig& rig,
                                             const Eigen::Vector2d& camera_px,
                                             double projector_coordinate_px,
                                             phase::FringeDirection direction,
                                             const TriangulationOptions& options) {
  return TriangulateCameraProjectorRay(rig, rig.camera.Ray(camera_px), projector_coordinate_px,
                                       direction, options);
}

TriangulatedPoint TriangulateCameraProjector(const CameraProjectorRig& rig,
                                             const Eigen::Vector2d& camera_px,
                                             const Eigen::Vector2d& projector_px,
                                             const TriangulationOptions& options) {
  return Triangulate(rig.AsTwoViewRig(), camera_px, projector_px, options);
}

namespace {

// Camera ray against the projector, per valid pixel (of every stack); see the header.
// The scheme's absolute phase is a projector coordinate only for the projector it was made for:
// a scheme for a 1280 x 800 projector decoded against a projector calibrated at 640 x 400 gives
// points, all wrong. Both sizes are compared (the images are the projector's size).
void CheckSchemeFitsProjector(const phase::PatternScheme& scheme, const CameraModel& projector) {
  if (!SchemeFitsProjector(scheme, projector)) {
    throw Error(util::StrCat("camera-projector: the pattern scheme '", scheme.name, "' is for a ",
                             scheme.projector_width, " x ", scheme.projector_height,
                             " projector, but the rig's projector is calibrated at ",
                             projector.width, " x ", projector.height,
                             " px; use the scheme the patterns were made with and the rig of "
                             "that projector"));
  }
}

class CameraProjectorCorrespondence : public Correspondence {
 public:
  CameraProjectorCorrespondence(const CameraProjectorRig& rig, const MatchingOptions& options)
      : rig_(rig), options_(options) {
    rig_.Check();
    options_.Check();
    rays_.resize(static_cast<size_t>(rig_.camera.width) * rig_.camera.height);
    tbb::parallel_for(tbb::blocked_range<int>(0, rig_.camera.height), [&](const auto& rows) {
      for (int r = rows.begin(); r < rows.end(); ++r) {
        for (int c = 0; c < rig_.camera.width; ++c) {
          rays_[static_cast<size_t>(r) * rig_.camera.width + c] =
              rig_.camera.Ray(Eigen::Vector2d(c, r));
        }
      }
    });
  }
  const char* Name() const override { return "camera-projector"; }
  const CameraModel& Left() const override { return rig_.camera; }
  bool UsesRight() const override { return false; }
  void CheckSchemes(const std::vector<phase::PatternScheme>& schemes) const override {
    if (schemes.empty() || schemes.size() > 2) {
      throw Error(
          util::StrCat("camera-projector: need one or two pattern schemes, got ", schemes.size()));
    }
    if (schemes.size() == 2 && schemes[0].direction == schemes[1].direction) {
      throw Error(util::StrCat("camera-projector: the two schemes '", schemes[0].name, "' and '",
                               schemes[1].name, "' have the same fringe direction (",
                               phase::DirectionName(schemes[0].direction),
                               "); two schemes must be one vertical and one horizontal"));
    }
    for (const phase::PatternScheme& s : schemes) CheckSchemeFitsProjector(s, rig_.projector);
  }
  void Correspond(const std::vector<phase::PatternScheme>& schemes, const DecodedView& view,
                  ViewReconstruction* out) const override;

  // One pixel (valid in every stack): the point, or a failed status.
  TriangulatedPoint Pixel(const std::vector<phase::PatternScheme>& schemes,
                          const std::vector<phase::DecodeResult>& decoded,
                          const StereoRig& two_view, int c, int r) const;
  const CameraProjectorRig& rig() const { return rig_; }

 private:
  CameraProjectorRig rig_;
  MatchingOptions options_;
  std::vector<Eigen::Vector3d> rays_;  // unit camera rays per pixel (row-major)
};

TriangulatedPoint CameraProjectorCorrespondence::Pixel(
    const std::vector<phase::PatternScheme>& schemes,
    const std::vector<phase::DecodeResult>& decoded, const StereoRig& two_view, int c,
    int r) const {
  const size_t i = static_cast<size_t>(r) * rig_.camera.width + c;
  if (decoded.size() == 2) {
    const int vertical_index = schemes[0].direction == phase::FringeDirection::kVertical ? 0 : 1;
    const double u = decoded[vertical_index].absolute_phase.at<float>(r, c);
    const double v = decoded[1 - vertical_index].absolute_phase.at<float>(r, c);
    const Eigen::Vector2d xy_proj = rig_.projector.Unproject(Eigen::Vector2d(u, v));
    return TriangulateFromRays(two_view, rays_[i], Eigen::Vector2d(c, r), xy_proj,
                               Eigen::Vector2d(u, v), options_.triangulation);
  }
  return TriangulateCameraProjectorRay(rig_, rays_[i], decoded[0].absolute_phase.at<float>(r, c),
                                       schemes[0].direction, options_.triangulation);
}

void CameraProjectorCorrespondence::Correspond(const std::vector<phase::PatternScheme>& schemes,
                                               const DecodedView& view,
                                               ViewReconstruction* out) const {
  util::Timer timer;
  const std::vector<phase::DecodeResult>& decoded = view.left;
  const CameraModel& cam = rig_.camera;
  // Per pixel; counts per row, summed in row order.
  const bool both = decoded.size() == 2;
  const StereoRig two_view = rig_.AsTwoViewRig();
  const MatchingOptions& mo = options_;
  std::vector<int> failed(cam.height, 0), out_of_range(cam.height, 0), residual(cam.height, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, cam.height), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      for (int c = 0; c < cam.width; ++c) {
        bool valid = true;
        for (const auto& d : decoded) valid = valid && d.mask.at<uint8_t>(r, c) != 0;
        if (!valid) continue;
        const size_t i = out->cloud.index(c, r);
        const TriangulatedPoint tp = Pixel(schemes, decoded, two_view, c, r);
        if (both && tp.ok() && tp.reprojection_error_px > mo.max_reprojection_error_px) {
          ++residual[r];
          continue;
        }
        if (!tp.ok()) {
          ++failed[r];
          continue;
        }
        if (tp.p_in_left.z() < mo.min_depth_mm || tp.p_in_left.z() > mo.max_depth_mm) {
          ++out_of_range[r];
          continue;
        }
        out->cloud.valid[i] = 1;
        out->cloud.cloud.points[i] = tp.p_in_left;
        out->cloud.cloud.quality[i] = decoded[0].modulation.at<float>(r, c);
        out->cloud.cloud.intensity[i] =
            static_cast<float>(decoded[0].background.at<float>(r, c) * view.texture_scale);
        out->reprojection_error_px.at<float>(r, c) = static_cast<float>(tp.reprojection_error_px);
      }
    }
  });
  MatchingSummary& m = out->summary.matching;
  for (int r = 0; r < cam.height; ++r) {
    m.triangulation_failed += failed[r];
    m.out_of_depth_range += out_of_range[r];
    m.large_residual += residual[r];
  }
  m.left_valid = static_cast<int>(cv::countNonZero(decoded[0].mask));
  m.points = static_cast<int>(out->cloud.NumValid());
  double sum = 0;
  for (size_t i = 0; i < out->cloud.valid.size(); ++i) {
    if (out->cloud.valid[i]) {
      sum += out->reprojection_error_px.at<float>(static_cast<int>(i / cam.width),
                                                  static_cast<int>(i % cam.width));
    }
  }
  m.mean_reprojection_error_px = m.points ? sum / m.points : 0;
  if (m.points == 0) {
    m.status = MatchingStatus::kNoPoints;
    m.message = "no valid pixel triangulated against the projector within the depth range";
  }
  m.time_s = timer.ElapsedSeconds();
}

// The decoded phase at a subpixel position: bilinear when the four pixels around it are valid,
// else the nearest valid pixel's; NaN outside the image or where the nearest pixel is invalid.
double PhaseAt(const phase::DecodeResult& d, const Eigen::Vector2d& px) {
  const int w = d.mask.cols, h = d.mask.rows;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!(px.x() > -0.5 && px.y() > -0.5 && px.x() < w - 0.5 && px.y() < h - 0.5)) return nan;
  const int c0 = static_cast<int>(std::floor(px.x())), r0 = static_cast<int>(std::floor(px.y()));
  if (c0 >= 0 && r0 >= 0 && c0 + 1 < w && r0 + 1 < h && d.mask.at<uint8_t>(r0, c0) &&
      d.mask.at<uint8_t>(r0, c0 + 1) && d.mask.at<uint8_t>(r0 + 1, c0) &&
      d.mask.at<uint8_t>(r0 + 1, c0 + 1)) {
    const double fx = px.x() - c0, fy = px.y() - r0;
    const cv::Mat& p = d.absolute_phase;
    return (1 - fy) * ((1 - fx) * p.at<float>(r0, c0) + fx * p.at<float>(r0, c0 + 1)) +
           fy * ((1 - fx) * p.at<float>(r0 + 1, c0) + fx * p.at<float>(r0 + 1, c0 + 1));
  }
  const int c = static_cast<int>(std::lround(px.x())), r = static_cast<int>(std::lround(px.y()));
  return d.mask.at<uint8_t>(r, c) ? d.absolute_phase.at<float>(r, c) : nan;
}

// Stereo, then the left-only pixels from the left camera + projector (see the header).
class TrinocularCorrespondence : public Correspondence {
 public:
  TrinocularCorrespondence(const StereoRig& rig, const MatchingOptions& options)
      : rig_(rig),
        options_(options),
        stereo_(MakeStereoCorrespondence(rig, options)),
        camera_projector_(CameraProjectorRig::FromLeftCamera(rig), options) {}
  const char* Name() const override { return "trinocular"; }
  const CameraModel& Left() const override { return rig_.left; }
  bool UsesRight() const override { return true; }
  const CameraModel* Right() const override { return &rig_.right; }
  void CheckSchemes(const std::vector<phase::PatternScheme>& schemes) const override {
    stereo_->CheckSchemes(schemes);
    // The projector fills pixels from its columns: the scheme must be for this projector.
    for (const phase::PatternScheme& s : schemes) CheckSchemeFitsProjector(s, *rig_.projector);
  }
  void Correspond(const std::vector<phase::PatternScheme>& schemes, const DecodedView& view,
                  ViewReconstruction* out) const override {
    stereo_->Correspond(schemes, view, out);
    util::Timer timer;
    const CameraModel& left = rig_.left;
    const CameraModel& right = rig_.right;
    const phase::DecodeResult& dl = view.left[0];
    const phase::DecodeResult& dr = view.right[0];
    const StereoRig two_view = camera_projector_.rig().AsTwoViewRig();
    // A phase tolerance in projector pixels: the projector check of stereo matching, or 1 px
    // when that check is off.
    const double phase_tol =
        options_.max_projector_error_px > 0 ? options_.max_projector_error_px : 1.0;
    std::vector<int> filled(left.height, 0);
    tbb::parallel_for(tbb::blocked_range<int>(0, left.height), [&](const auto& rows) {
      for (int r = rows.begin(); r < rows.end(); ++r) {
        for (int c = 0; c < left.width; ++c) {
          const size_t i = out->cloud.index(c, r);
          if (out->cloud.valid[i] || dl.mask.at<uint8_t>(r, c) == 0) continue;
          const TriangulatedPoint tp = camera_projector_.Pixel(schemes, view.left, two_view, c, r);
          if (!tp.ok() || tp.p_in_left.z() < options_.min_depth_mm ||
              tp.p_in_left.z() > options_.max_depth_mm) {
            continue;
          }
          // Seen by the right camera? Then stereo decided, and the pixel stays empty.
          const Eigen::Vector3d p_in_right = rig_.right_from_left * tp.p_in_left;
          if (p_in_right.z() > 0) {
            const double right_phase = PhaseAt(dr, right.Project(p_in_right));
            if (std::isfinite(right_phase) &&
                std::abs(right_phase - dl.absolute_phase.at<float>(r, c)) <= phase_tol) {
              continue;
            }
          }
          out->cloud.valid[i] = 1;
          out->cloud.cloud.points[i] = tp.p_in_left;
          if (out->cloud.cloud.has_quality()) {
            out->cloud.cloud.quality[i] = dl.modulation.at<float>(r, c);
          }
          if (out->cloud.cloud.has_intensity()) {
            out->cloud.cloud.intensity[i] =
                static_cast<float>(dl.background.at<float>(r, c) * view.texture_scale);
          }
          out->reprojection_error_px.at<float>(r, c) = static_cast<float>(tp.reprojection_error_px);
          ++filled[r];
        }
      }
    });
    MatchingSummary& m = out->summary.matching;
    for (int r = 0; r < left.height; ++r) m.projector_filled += filled[r];
    m.points = static_cast<int>(out->cloud.NumValid());
    if (m.points > 0 && m.status == MatchingStatus::kNoPoints) {
      m.status = MatchingStatus::kOk;
      m.message.clear();
    }
    m.time_s += timer.ElapsedSeconds();
  }

 private:
  StereoRig rig_;
  MatchingOptions options_;
  std::shared_ptr<const Correspondence> stereo_;
  CameraProjectorCorrespondence camera_projector_;
};

}  // namespace

std::shared_ptr<const Correspondence> MakeCameraProjectorCorrespondence(
    const CameraProjectorRig& rig, const MatchingOptions& options) {
  return std::make_shared<CameraProjectorCorrespondence>(rig, options);
}

ViewReconstructor MakeCameraProjectorReconstructor(const CameraProjectorRig& rig,
                                                   const std::vector<phase::PatternScheme>& schemes,
                                                   const ReconstructionOptions& options) {
  return ViewReconstructor(MakeCameraProjectorCorrespondence(rig, options.matching), schemes,
                           options);
}

std::shared_ptr<const Correspondence> MakeTrinocularCorrespondence(const StereoRig& rig,
                                                                   const MatchingOptions& options) {
  return std::make_shared<TrinocularCorrespondence>(rig, options);
}

}  // namespace fringe::stereo
