#include "fringe/stereo/reconstruct_view.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <limits>

#include "fringe/phase/decode.h"
#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::stereo {
namespace {

// texture: the background already on the 0-255 scale (CV_32F), shared instead of converted
// again; empty: converted here, or left empty when with_texture is false (the matcher reads
// the left camera's texture only).
PhaseImage ToPhaseImage(const phase::DecodeResult& d, double texture_scale, const cv::Mat& texture,
                        bool with_texture) {
  PhaseImage p;
  p.phase = d.absolute_phase;
  p.mask = d.mask;
  p.modulation = d.modulation;
  if (!with_texture) return p;
  if (texture.type() == CV_32FC1 && texture.size() == d.background.size()) {
    p.texture = texture;
  } else {
    d.background.convertTo(p.texture, CV_32F, texture_scale);
  }
  return p;
}

class StereoCorrespondence : public Correspondence {
 public:
  StereoCorrespondence(const StereoRig& rig, const MatchingOptions& options)
      : rig_((rig.Check(), rig)), matcher_(rig, options) {}
  const char* Name() const override { return "stereo"; }
  bool MakesCloud() const override { return true; }
  const CameraModel& Left() const override { return rig_.left; }
  bool UsesRight() const override { return true; }
  const CameraModel* Right() const override { return &rig_.right; }
  void CheckSchemes(const std::vector<phase::PatternScheme>& schemes) const override {
    if (schemes.size() != 1) {
      throw Error(
          util::StrCat("reconstruct: stereo matching takes one scheme, got ", schemes.size()));
    }
    const phase::PatternScheme& scheme = schemes[0];
    if (scheme.direction != phase::FringeDirection::kVertical) {
      throw Error(util::StrCat("reconstruct: scheme '", scheme.name, "' has ",
                               phase::DirectionName(scheme.direction),
                               " fringes; stereo matching needs vertical fringes (the absolute "
                               "phase must vary along the epipolar rows)"));
    }
  }
  void Correspond(const std::vector<phase::PatternScheme>& /*schemes*/, const DecodedView& view,
                  ViewReconstruction* out) const override {
    MatchResult m =
        matcher_.Match(ToPhaseImage(view.left[0], view.texture_scale, out->texture_left, true),
                       ToPhaseImage(view.right[0], view.texture_scale, cv::Mat(), false));
    out->summary.matching = m.summary;
    out->cloud = std::move(m.cloud);
    out->reprojection_error_px = m.reprojection_error_px;
  }

 private:
  StereoRig rig_;
  PhaseMatcher matcher_;
};

}  // namespace

void ReconstructionOptions::Check() const {
  decode.Check();
  matching.Check();
  outliers.Check();
  normals.Check();
}

const char* ToString(ReconstructionStatus s) {
  switch (s) {
    case ReconstructionStatus::kOk:
      return "ok";
    case ReconstructionStatus::kNoValidPixels:
      return "no valid pixels";
    case ReconstructionStatus::kNoPoints:
      return "no points";
  }
  return "?";
}

std::string ReconstructionSummary::BriefReport() const {
  std::string s = util::StrCat("reconstruction: ", ToString(status), ", ", points, " points in ",
                               total_s, " s (decode ", decode_s, " s, match ", match_s,
                               " s, outliers ", outliers_s, " s, normals ", normals_s, " s)");
  if (!message.empty()) s += ": " + message;
  return s;
}

nlohmann::json ToJson(const ReconstructionSummary& s) {
  const MatchingSummary& m = s.matching;
  return {{"status", ToString(s.status)},
          {"message", s.message},
          {"points", s.points},
          {"decode_left", phase::ToJson(s.decode_left)},
          {"decode_right", phase::ToJson(s.decode_right)},
          {"matching",
           {{"status", ToString(m.status)},
            {"message", m.message},
            {"left_valid", m.left_valid},
            {"no_crossing", m.no_crossing},
            {"ambiguous", m.ambiguous},
            {"discontinuity", m.discontinuity},
            {"lr_inconsistent", m.lr_inconsistent},
            {"triangulation_failed", m.triangulation_failed},
            {"large_residual", m.large_residual},
            {"projector_inconsistent", m.projector_inconsistent},
            {"out_of_depth_range", m.out_of_depth_range},
            {"projector_filled", m.projector_filled},
            {"points", m.points},
            {"mean_reprojection_error_px", m.mean_reprojection_error_px},
            {"warning", m.warning},
            {"report", m.BriefReport()}}},
          {"outliers",
           {{"status", ToString(s.outliers.status)},
            {"message", s.outliers.message},
            {"flying_pixels", s.outliers.flying_pixels},
            {"small_components", s.outliers.small_components},
            {"component_points", s.outliers.component_points},
            {"kept", s.outliers.kept},
            {"report", s.outliers.BriefReport()}}},
          {"normals",
           {{"status", ToString(s.normals.status)},
            {"message", s.normals.message},
            {"normals", s.normals.normals},
            {"missing", s.normals.missing},
            {"edge_points", s.normals.edge_points},
            {"report", s.normals.BriefReport()}}},
          {"timing_s",
           {{"decode", s.decode_s},
            {"match", s.match_s},
            {"outliers", s.outliers_s},
            {"normals", s.normals_s},
            {"total", s.total_s}}},
          {"report", s.BriefReport()}};
}

std::shared_ptr<const Correspondence> MakeStereoCorrespondence(const StereoRig& rig,
                                                               const MatchingOptions& options) {
  return std::make_shared<StereoCorrespondence>(rig, options);
}

ViewReconstructor::ViewReconstructor(std::shared_ptr<const Correspondence> correspondence,
                                     std::vector<phase::PatternScheme> schemes,
                                     const ReconstructionOptions& options)
    : correspondence_(std::move(correspondence)), schemes_(std::move(schemes)), options_(options) {
  if (!correspondence_) throw Error("reconstruct: no correspondence given");
  options_.Check();
  for (const auto& s : schemes_) s.Check();
  correspondence_->CheckSchemes(schemes_);
}

ViewReconstructor::ViewReconstructor(const StereoRig& rig, const phase::PatternScheme& scheme,
                                     const ReconstructionOptions& options)
    : ViewReconstructor((rig.Check(), scheme.Check(),
                         MakeStereoCorrespondence(rig, (options.Check(), options.matching))),
                        {scheme}, options) {}

ViewReconstruction ViewReconstructor::Reconstruct(const std::vector<cv::Mat>& left_images,
                                                  const std::vector<cv::Mat>& right_images) const {
  ViewStacks stacks;
  stacks.left.push_back(left_images);
  if (correspondence_->UsesRight()) stacks.right.push_back(right_images);
  return Reconstruct(stacks);
}

ViewReconstruction ViewReconstructor::Reconstruct(
    const std::vector<std::vector<cv::Mat>>& left_exposures,
    const std::vector<std::vector<cv::Mat>>& right_exposures) const {
  if (left_exposures.empty()) throw Error("reconstruct: no left image stack");
  ViewStacks stacks;
  stacks.left.push_back(left_exposures[0]);
  stacks.more_left_exposures.assign(left_exposures.begin() + 1, left_exposures.end());
  if (correspondence_->UsesRight()) {
    if (right_exposures.empty()) throw Error("reconstruct: no right image stack");
    stacks.right.push_back(right_exposures[0]);
    stacks.more_right_exposures.assign(right_exposures.begin() + 1, right_exposures.end());
  }
  return Reconstruct(stacks);
}

ViewReconstruction ViewReconstructor::Reconstruct(const ViewStacks& stacks) const {
  util::Timer total;
  ViewReconstruction out;
  ReconstructionSummary& s = out.summary;
  const Correspondence& corr = *correspondence_;
  const bool two_cameras = corr.UsesRight();
  if (stacks.left.size() != schemes_.size() ||
      (two_cameras && stacks.right.size() != schemes_.size())) {
    throw Error(
        util::StrCat("reconstruct: ", stacks.left.size(), " left",
                     two_cameras ? util::StrCat(" and ", stacks.right.size(), " right") : "",
                     " image stack(s) for ", schemes_.size(), " scheme(s)"));
  }
  auto check_size = [&](const std::vector<std::vector<cv::Mat>>& imgs, const CameraModel& cam,
                        const char* side) {
    for (size_t k = 0; k < imgs.size(); ++k) {
      if (!imgs[k].empty() && (imgs[k][0].cols != cam.width || imgs[k][0].rows != cam.height)) {
        throw Error(util::StrCat(
            "reconstruct: ", side, " images",
            schemes_.size() > 1 ? " of scheme '" + schemes_[k % schemes_.size()].name + "'" : "",
            " are ", imgs[k][0].cols, "x", imgs[k][0].rows, " but the rig's ", side, " camera is ",
            cam.width, "x", cam.height));
      }
    }
  };
  check_size(stacks.left, corr.Left(), "left");
  check_size(stacks.more_left_exposures, corr.Left(), "left");
  if (two_cameras) {
    check_size(stacks.right, *corr.Right(), "right");
    check_size(stacks.more_right_exposures, *corr.Right(), "right");
  }
  const size_t n_schemes = schemes_.size();
  if (stacks.more_left_exposures.size() % n_schemes != 0 ||
      stacks.more_right_exposures.size() % n_schemes != 0) {
    throw Error(util::StrCat("reconstruct: ", stacks.more_left_exposures.size(), " left and ",
                             stacks.more_right_exposures.size(),
                             " right further exposure stacks for ", n_schemes,
                             " schemes (every exposure needs a stack of every scheme)"));
  }
  // Scheme k's stack with its further exposures of the same view (exposure-major, see
  // ViewStacks): phase::DecodeExposures keeps per pixel the best unsaturated one.
  auto exposures = [n_schemes](const std::vector<cv::Mat>& first,
                               const std::vector<std::vector<cv::Mat>>& more, size_t k) {
    std::vector<std::vector<cv::Mat>> all = {first};
    for (size_t i = k; i < more.size(); i += n_schemes) all.push_back(more[i]);
    return all;
  };

  util::Timer timer;
  DecodedView decoded;
  for (size_t k = 0; k < schemes_.size(); ++k) {
    decoded.left.push_back(phase::DecodeExposures(
        schemes_[k], exposures(stacks.left[k], stacks.more_left_exposures, k), options_.decode));
    if (two_cameras) {
      decoded.right.push_back(phase::DecodeExposures(
          schemes_[k], exposures(stacks.right[k], stacks.more_right_exposures, k),
          options_.decode));
    }
  }
  s.decode_left = decoded.left[0].summary;
  if (two_cameras) {
    s.decode_right = decoded.right[0].summary;
  } else if (decoded.left.size() > 1) {
    s.decode_right = decoded.left[1].summary;
  }
  s.decode_s = timer.ElapsedSeconds();
  // Texture on the 0-255 scale from the full scale the decoder used (the bit depth's, e.g.
  // 4095 for 12-bit data in 16-bit images), not the container's.
  decoded.texture_scale = 255.0 / decoded.left[0].summary.full_scale_dn;
  decoded.left[0].background.convertTo(out.texture_left, CV_32F, decoded.texture_scale);
  if (two_cameras) {
    decoded.right[0].background.convertTo(out.texture_right, CV_32F, decoded.texture_scale);
  }
  out.phase_left = decoded.left[0].absolute_phase;
  if (two_cameras) out.phase_right = decoded.right[0].absolute_phase;
  const CameraModel& cam = corr.Left();
  auto prepare_cloud = [&] {
    out.cloud = OrganizedPointCloud(cam.width, cam.height, false, true, true);
    out.reprojection_error_px =
        cv::Mat(cam.height, cam.width, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  };
  if (!corr.MakesCloud()) prepare_cloud();
  // No valid pixel in a stack: nothing to correspond (named by camera, or by scheme when one
  // camera has several).
  for (int side = 0; side < (two_cameras ? 2 : 1); ++side) {
    const auto& results = side == 0 ? decoded.left : decoded.right;
    for (size_t k = 0; k < results.size(); ++k) {
      const phase::DecodeSummary& d = results[k].summary;
      if (d.status == phase::DecodeStatus::kSuccess) continue;
      s.status = ReconstructionStatus::kNoValidPixels;
      s.message = two_cameras ? util::StrCat("the fringe decoder found no valid pixel in the ",
                                             side == 0 ? "left" : "right", " images (",
                                             d.BriefReport(), ")")
                              : util::StrCat(
                                    "the fringe decoder found no valid pixel in the camera "
                                    "images of '",
                                    schemes_[k].name, "' (", d.BriefReport(), ")");
      if (corr.MakesCloud()) prepare_cloud();
      s.total_s = total.ElapsedSeconds();
      return out;
    }
  }

  timer.Restart();
  corr.Correspond(schemes_, decoded, &out);
  s.match_s = timer.ElapsedSeconds();
  FinishViewReconstruction(cam.fx, options_, &out);
  s.total_s = total.ElapsedSeconds();
  return out;
}

void FinishViewReconstruction(double focal_px, const ReconstructionOptions& options,
                              ViewReconstruction* out) {
  ReconstructionSummary& s = out->summary;
  util::Timer timer;
  if (options.remove_outliers) {
    timer.Restart();
    s.outliers = RemoveOrganizedOutliers(&out->cloud, focal_px, options.outliers);
    s.outliers_s = timer.ElapsedSeconds();
  }
  // The residual travels with each point (PLY property residual_px) so that later stages
  // (fusion) can weigh points without the image beside the cloud; NaN where outlier removal
  // took the point (in the image too). Rows in parallel.
  const OrganizedPointCloud& cloud = out->cloud;
  std::vector<float>& residual = out->cloud.cloud.residual_px;
  residual.resize(cloud.valid.size());
  tbb::parallel_for(tbb::blocked_range<int>(0, cloud.height), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      float* err = out->reprojection_error_px.ptr<float>(r);
      for (int c = 0; c < cloud.width; ++c) {
        const size_t i = cloud.index(c, r);
        if (options.remove_outliers && !cloud.valid[i]) {
          err[c] = std::numeric_limits<float>::quiet_NaN();
        }
        residual[i] = err[c];
      }
    }
  });
  if (options.compute_normals) {
    timer.Restart();
    s.normals = EstimateGridNormals(&out->cloud, options.normals);
    s.normals_s = timer.ElapsedSeconds();
  }
  s.points = static_cast<int>(out->cloud.NumValid());
  if (s.points == 0) {
    s.status = ReconstructionStatus::kNoPoints;
    s.message = s.matching.BriefReport();
  }
}

ViewReconstruction ReconstructView(const StereoRig& rig, const phase::PatternScheme& scheme,
                                   const std::vector<cv::Mat>& left_images,
                                   const std::vector<cv::Mat>& right_images,
                                   const ReconstructionOptions& options) {
  return ViewReconstructor(rig, scheme, options).Reconstruct(left_images, right_images);
}

}  // namespace fringe::stereo
