// bench_calibration_predict: is the predicted depth uncertainty of a calibration right? (issue 26)
//
// The reference rig sees the reference board in seeded poses (sim::GenerateBoardPoses, the
// poses bench_calibration uses); each of `--calibrations` stereo calibrations gets the true
// projected centres plus fresh Gaussian noise of the detector's measured centre error (RMS
// 0.0066 px in 2D on simulator images, docs/benchmarks.md "Calibration": 0.0047 px per axis),
// and is calibrated with CalibrateStereo. At the working volume's centre and eight corners
// (calib/diagnostics.h: the box spanned by the board points) the true pixel pair of the point is
// triangulated with each calibrated rig; the spread (standard deviation) of its depth over the
// calibrations is compared with the depth sigma each calibration predicts from its own
// covariance (PredictedDepthSigmaMm; the median over the calibrations).
//
// Detections are synthesised rather than rendered so that 50 calibrations take seconds; the
// noise is the detector's, and the calibration code is the same.
//
// Usage: bench_calibration_predict [--json] [--calibrations N] [--poses P] [--noise-px S]
//        [--seed S]
// JSON: predicted_sigma_over_spread (the centre's; target within 20 %: 0.8 - 1.2),
// predicted_depth_sigma_mm, depth_spread_mm, per point the same, calibrations, poses, seconds.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "fringe/calib/calibrate.h"
#include "fringe/calib/diagnostics.h"
#include "fringe/sim/board.h"
#include "fringe/util/random.h"
#include "fringe/util/timer.h"

namespace fringe {
namespace {

using nlohmann::json;

// Midpoint triangulation of a pixel pair with a rig (left frame).
Eigen::Vector3d Triangulate(const StereoRig& rig, const Eigen::Vector2d& ul,
                            const Eigen::Vector2d& ur) {
  const Eigen::Vector3d dl = rig.left.Unproject(ul).homogeneous();
  const Eigen::Matrix3d r_t = rig.right_from_left.rotation_matrix().transpose();
  const Eigen::Vector3d c = -r_t * rig.right_from_left.translation();
  const Eigen::Vector3d dr = r_t * rig.right.Unproject(ur).homogeneous();
  const double a = dl.dot(dl), b = dl.dot(dr), cc = dr.dot(dr), d = dl.dot(c), e = dr.dot(c);
  const double det = a * cc - b * b;
  const double s = (d * cc - b * e) / det, t = (b * d - a * e) / det;
  return 0.5 * (s * dl + c + t * dr);
}

calib::TargetDetection Detect(const CameraModel& camera, const CalibrationTarget& target,
                              const Rigid3d& camera_from_board, double noise_px, util::Rng* rng) {
  std::normal_distribution<double> noise(0, noise_px);
  calib::TargetDetection d;
  d.image_width = camera.width;
  d.image_height = camera.height;
  for (int r = 0; r < target.rows; ++r) {
    for (int c = 0; c < target.cols; ++c) {
      const Eigen::Vector3d p = camera_from_board * target.FeatureCentre(r, c);
      if (p.z() <= 0) continue;
      const Eigen::Vector2d px = camera.Project(p);
      if (px.x() < 0 || px.y() < 0 || px.x() > camera.width - 1 || px.y() > camera.height - 1) {
        continue;
      }
      calib::FeatureObservation f;
      f.row = r;
      f.col = c;
      f.centre_px = px + Eigen::Vector2d(noise(*rng), noise(*rng));
      d.features.push_back(f);
    }
  }
  d.status =
      d.features.size() >= 6 ? calib::DetectionStatus::kOk : calib::DetectionStatus::kNotFound;
  return d;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? NAN : v[v.size() / 2];
}

double StdDev(const std::vector<double>& v) {
  double mean = 0;
  for (double x : v) mean += x;
  mean /= v.size();
  double ss = 0;
  for (double x : v) ss += (x - mean) * (x - mean);
  return std::sqrt(ss / (v.size() - 1));
}

}  // namespace
}  // namespace fringe

int main(int argc, char** argv) {
  using namespace fringe;
  CLI::App app{"Predicted depth uncertainty of a calibration vs the spread over calibrations"};
  bool as_json = false;
  int calibrations = 50, poses = 20;
  double noise_px = 0.0066 / std::sqrt(2.0);
  uint64_t seed = 1;
  app.add_flag("--json", as_json, "Print one JSON object");
  app.add_option("--calibrations", calibrations, "Simulated calibrations, >= 3")
      ->check(CLI::Range(3, 10000));
  app.add_option("--poses", poses, "Board poses per calibration")->check(CLI::Range(3, 200));
  app.add_option("--noise-px", noise_px, "Centre noise per axis, px")->check(CLI::PositiveNumber);
  app.add_option("--seed", seed, "Seed (poses, noise)");
  CLI11_PARSE(app, argc, argv);

  util::Timer timer;
  const StereoRig truth = [] {
    StereoRig r = StereoRig::Reference();
    r.projector.reset();
    return r;
  }();
  const CalibrationTarget target = CalibrationTarget::Reference();
  sim::BoardPoseOptions po;
  po.count = poses;
  po.seed = seed;
  const std::vector<Rigid3d> left_from_board = sim::GenerateBoardPoses(truth, target, po);

  // The working volume of the true poses (as DiagnoseCalibration spans it).
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const Rigid3d& p : left_from_board) {
    for (const Eigen::Vector3d& f : target.FeatureCentres()) {
      lo = lo.cwiseMin(p * f);
      hi = hi.cwiseMax(p * f);
    }
  }
  std::vector<std::pair<std::string, Eigen::Vector3d>> points = {{"centre", 0.5 * (lo + hi)}};
  for (int k = 0; k < 8; ++k) {
    points.push_back({"corner " + std::to_string(k + 1),
                      Eigen::Vector3d((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(),
                                      (k & 4) ? hi.z() : lo.z())});
  }
  std::vector<std::vector<double>> depth(points.size()), predicted(points.size());
  int failed = 0;
  for (int c = 0; c < calibrations; ++c) {
    util::Rng rng(util::MixSeed(seed, static_cast<uint64_t>(c) + 1));
    std::vector<calib::TargetDetection> left, right;
    for (const Rigid3d& p : left_from_board) {
      left.push_back(Detect(truth.left, target, p, noise_px, &rng));
      right.push_back(Detect(truth.right, target, truth.right_from_left * p, noise_px, &rng));
    }
    const calib::StereoCalibration cal =
        calib::CalibrateStereo(left, right, target, truth.left.width, truth.left.height);
    if (!cal.summary.ok() || cal.rig_covariance.rows() == 0) {
      ++failed;
      continue;
    }
    for (size_t k = 0; k < points.size(); ++k) {
      const Eigen::Vector3d& x = points[k].second;
      const Eigen::Vector2d ul = truth.left.Project(x);
      const Eigen::Vector2d ur = truth.right.Project(truth.right_from_left * x);
      depth[k].push_back(Triangulate(cal.rig, ul, ur).z());
      predicted[k].push_back(calib::PredictedDepthSigmaMm(cal.rig, cal.rig_covariance, x));
    }
  }
  json per_point = json::array();
  double worst_ratio = 1;
  for (size_t k = 0; k < points.size(); ++k) {
    const double spread = depth[k].size() >= 3 ? StdDev(depth[k]) : NAN;
    const double pred = Median(predicted[k]);
    const double ratio = pred / spread;
    if (std::abs(std::log(ratio)) > std::abs(std::log(worst_ratio))) worst_ratio = ratio;
    const Eigen::Vector3d& x = points[k].second;
    per_point.push_back({{"where", points[k].first},
                         {"point_in_left_mm", {x.x(), x.y(), x.z()}},
                         {"predicted_depth_sigma_mm", pred},
                         {"depth_spread_mm", spread},
                         {"predicted_over_spread", ratio}});
  }
  json j = {{"bench", "calibration_predict"},
            {"calibrations", calibrations},
            {"failed_calibrations", failed},
            {"poses", poses},
            {"noise_px_per_axis", noise_px},
            {"seed", seed},
            {"predicted_sigma_over_spread", per_point[0]["predicted_over_spread"]},
            {"predicted_depth_sigma_mm", per_point[0]["predicted_depth_sigma_mm"]},
            {"depth_spread_mm", per_point[0]["depth_spread_mm"]},
            {"worst_predicted_over_spread", worst_ratio},
            {"points", per_point},
            {"seconds", timer.ElapsedSeconds()}};
  if (as_json) {
    std::cout << j.dump(2) << "\n";
  } else {
    std::cout << "predicted depth sigma vs spread over " << calibrations - failed
              << " calibrations (" << poses << " poses, noise " << noise_px << " px per axis)\n";
    for (const json& p : per_point) {
      std::cout << "  " << p["where"].get<std::string>() << ": predicted "
                << 1000 * p["predicted_depth_sigma_mm"].get<double>() << " um, spread "
                << 1000 * p["depth_spread_mm"].get<double>() << " um, ratio "
                << p["predicted_over_spread"].get<double>() << "\n";
    }
    std::cout << "predicted_sigma_over_spread (centre) "
              << j["predicted_sigma_over_spread"].get<double>() << ", " << timer.ElapsedSeconds()
              << " s\n";
  }
  return 0;
}
