#include "fringe/stereo/reconstruct_view.h"

#include <limits>

#include "fringe/phase/decode.h"
#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::stereo {
namespace {

PhaseImage ToPhaseImage(const phase::DecodeResult& d, double texture_scale) {
  PhaseImage p;
  p.phase = d.absolute_phase;
  p.mask = d.mask;
  p.modulation = d.modulation;
  d.background.convertTo(p.texture, CV_32F, texture_scale);
  return p;
}

const StereoRig& CheckedRig(const StereoRig& rig, const phase::PatternScheme& scheme) {
  rig.Check();
  scheme.Check();
  if (scheme.direction != phase::FringeDirection::kVertical) {
    throw Error(util::StrCat("reconstruct: scheme '", scheme.name, "' has ",
                             phase::DirectionName(scheme.direction),
                             " fringes; stereo matching needs vertical fringes (the absolute "
                             "phase must vary along the epipolar rows)"));
  }
  return rig;
}

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

nlohmann::json SummaryToJson(const ReconstructionSummary& s) {
  const MatchingSummary& m = s.matching;
  return {{"status", ToString(s.status)},
          {"message", s.message},
          {"points", s.points},
          {"decode_left", phase::SummaryToJson(s.decode_left)},
          {"decode_right", phase::SummaryToJson(s.decode_right)},
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

ViewReconstructor::ViewReconstructor(const StereoRig& rig, const phase::PatternScheme& scheme,
                                     const ReconstructionOptions& options)
    : rig_(CheckedRig(rig, scheme)),
      scheme_(scheme),
      options_((options.Check(), options)),
      matcher_(rig, options.matching) {}

ViewReconstruction ViewReconstructor::Reconstruct(const std::vector<cv::Mat>& left_images,
                                                  const std::vector<cv::Mat>& right_images) const {
  util::Timer total;
  ViewReconstruction out;
  ReconstructionSummary& s = out.summary;
  auto check_size = [](const std::vector<cv::Mat>& imgs, const CameraModel& cam, const char* side) {
    if (!imgs.empty() && (imgs[0].cols != cam.width || imgs[0].rows != cam.height)) {
      throw Error(util::StrCat("reconstruct: ", side, " images are ", imgs[0].cols, "x",
                               imgs[0].rows, " but the rig's ", side, " camera is ", cam.width, "x",
                               cam.height));
    }
  };
  check_size(left_images, rig_.left, "left");
  check_size(right_images, rig_.right, "right");

  util::Timer timer;
  const phase::DecodeResult dl = phase::Decode(scheme_, left_images, options_.decode);
  const phase::DecodeResult dr = phase::Decode(scheme_, right_images, options_.decode);
  s.decode_left = dl.summary;
  s.decode_right = dr.summary;
  s.decode_s = timer.ElapsedSeconds();
  // Texture on the 0-255 scale from the full scale the decoder used (the bit depth's, e.g.
  // 4095 for 12-bit data in 16-bit images), not the container's.
  const double texture_scale = 255.0 / dl.summary.full_scale_dn;
  dl.background.convertTo(out.texture_left, CV_32F, texture_scale);
  dr.background.convertTo(out.texture_right, CV_32F, texture_scale);
  out.cloud = OrganizedPointCloud(rig_.left.width, rig_.left.height);
  if (dl.summary.status != phase::DecodeStatus::kSuccess ||
      dr.summary.status != phase::DecodeStatus::kSuccess) {
    s.status = ReconstructionStatus::kNoValidPixels;
    s.message = util::StrCat("the fringe decoder found no valid pixel in the ",
                             dl.summary.valid == 0 ? "left" : "right", " images (",
                             (dl.summary.valid == 0 ? dl : dr).summary.BriefReport(), ")");
    s.total_s = total.ElapsedSeconds();
    return out;
  }

  timer.Restart();
  MatchResult m = matcher_.Match(ToPhaseImage(dl, texture_scale), ToPhaseImage(dr, texture_scale));
  s.matching = m.summary;
  s.match_s = timer.ElapsedSeconds();
  out.cloud = std::move(m.cloud);
  out.reprojection_error_px = m.reprojection_error_px;
  FinishViewReconstruction(rig_.left.fx, options_, &out);
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
    for (size_t i = 0; i < out->cloud.valid.size(); ++i) {
      if (!out->cloud.valid[i]) {
        out->reprojection_error_px.at<float>(static_cast<int>(i / out->cloud.width),
                                             static_cast<int>(i % out->cloud.width)) =
            std::numeric_limits<float>::quiet_NaN();
      }
    }
  }
  // The residual travels with each point (PLY property residual_px) so that later stages
  // (fusion) can weigh points without the image beside the cloud.
  out->cloud.cloud.residual_px.assign(out->reprojection_error_px.begin<float>(),
                                      out->reprojection_error_px.end<float>());
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
