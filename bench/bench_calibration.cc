// bench_calibration: accuracy and speed of board detection and stereo calibration on simulator
// images with ground truth (issue 5), ours vs OpenCV on the SAME images in the same process.
//
// The simulator's reference rig (2 x 1280x1024, f ~ 2500 px, read noise 1.5 DN) sees the board
// in seeded poses with tilts 0-60 degrees, the whole board visible in both cameras so OpenCV's
// symmetric-grid finder can work too. Two boards, same layout (7 x 9 at 24 mm, radius 8 mm):
//   rings   - the reference concentric-ring board: ours = pole-polar true centres;
//             OpenCV = findCirclesGrid (SimpleBlobDetector centroid of each dark annulus).
//   circles - solid circles: ours = ellipse centres corrected for perspective bias from the
//             estimated pose during calibration; OpenCV = findCirclesGrid.
// Per board: feature-centre error vs the TRUE projected centres (RMS, max; ours are the final
// centres used by the calibration), per tilt bin; intrinsic errors (fx fy cx cy px, k1 k2) and
// baseline error (mm, angle) of CalibrateStereo vs cv::calibrateCamera + cv::stereoCalibrate
// (CALIB_USE_INTRINSIC_GUESS) given OpenCV's centres in the true order; detection rate;
// detection time per image.
//
// Usage: bench_calibration [--json] [--poses N] [--seed S]
// The top-level JSON keys are the rings board's; "circles" holds the same keys for solid
// circles, "tilt_bins" the per-tilt centre errors.
#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <string>
#include <vector>

#include "bench_timing.h"
#include "fringe/calib/calibrate.h"
#include "fringe/calib/detect.h"
#include "fringe/sim/board.h"
#include "fringe/util/timer.h"

namespace fringe {
namespace {

using nlohmann::json;

struct ErrStats {
  double ss = 0, max = 0;
  int n = 0;
  void Add(double e) {
    ss += e * e;
    max = std::max(max, e);
    ++n;
  }
  double Rms() const { return n ? std::sqrt(ss / n) : std::nan(""); }
};

struct Result {
  std::string board;
  ErrStats ours, opencv, ours_detect;
  std::vector<ErrStats> ours_tilt, opencv_tilt;  // per tilt bin
  double focal_err_pct = NAN, opencv_focal_err_pct = NAN;
  double cxcy_err_px = NAN, opencv_cxcy_err_px = NAN;
  double k1_err = NAN, opencv_k1_err = NAN, k2_err = NAN, opencv_k2_err = NAN;
  double baseline_err_mm = NAN, opencv_baseline_err_mm = NAN;
  double angle_err_deg = NAN, opencv_angle_err_deg = NAN;
  double rms_px = NAN, opencv_rms_px = NAN;
  int images = 0, ours_found = 0, opencv_found = 0;
  double ours_ms = 0, opencv_ms = 0;
  // One stereo calibration (detections given): wall time and process CPU time (the CPU time
  // stays comparable on a shared machine; both solvers run single-threaded).
  double calib_ms = NAN, opencv_calib_ms = NAN, calib_cpu_ms = NAN, opencv_calib_cpu_ms = NAN;
};

constexpr double kTiltBinDeg = 15;
constexpr int kTiltBins = 4;

// Angle between the board normal and the line of sight to the board centre (7 x 9 at 24 mm).
double TiltDeg(const Rigid3d& cam_from_board) {
  const Eigen::Vector3d n = cam_from_board.rotation_matrix().col(2);
  const Eigen::Vector3d to_board = (cam_from_board * Eigen::Vector3d(96, 72, 0)).normalized();
  return std::acos(std::min(1.0, std::abs(n.dot(to_board)))) * 180 / M_PI;
}

int TiltBin(double tilt) {
  return std::clamp(static_cast<int>(tilt / kTiltBinDeg), 0, kTiltBins - 1);
}

// OpenCV's symmetric circle-grid finder on dark blobs of any size on this image scale.
bool OpenCvCircles(const cv::Mat& img, const CalibrationTarget& t, std::vector<cv::Point2f>* c) {
  cv::SimpleBlobDetector::Params p;
  p.minArea = 300;  // above the rings' centre dots
  p.maxArea = 1e5;
  p.filterByInertia = false;
  p.filterByConvexity = false;
  const auto detector = cv::SimpleBlobDetector::create(p);
  return cv::findCirclesGrid(img, cv::Size(t.cols, t.rows), *c, cv::CALIB_CB_SYMMETRIC_GRID,
                             detector);
}

double PctErr(double a, double b) { return 100 * std::abs(a - b) / std::abs(b); }

// Per pose and camera: our detections and the true centres; OpenCV's centres reordered to the
// true (row, col) order (NaN where missing), and whether both of its boards are complete.
struct Detections {
  std::vector<calib::TargetDetection> left, right;
  std::vector<std::vector<Eigen::Vector2d>> truth_l, truth_r;
  std::vector<std::vector<cv::Point2f>> cv_l, cv_r;
  std::vector<bool> cv_ok;
};

// OpenCV's centres matched to the nearest true centre (gives OpenCV the correct order; its
// 180-degree flips do not count); their errors go to r. False when a feature is missing.
bool OrderOpenCvCentres(const std::vector<cv::Point2f>& c, const sim::BoardImage& bi,
                        const CalibrationTarget& target, Result* r,
                        std::vector<cv::Point2f>* ordered) {
  ordered->assign(target.NumFeatures(), cv::Point2f(NAN, NAN));
  const double tilt = TiltDeg(bi.cam_from_board);
  for (const auto& p : c) {
    int best = -1;
    double bd = 1e300;
    for (int k = 0; k < target.NumFeatures(); ++k) {
      const double d = std::hypot(p.x - bi.centres_px[k].x(), p.y - bi.centres_px[k].y());
      if (d < bd) {
        bd = d;
        best = k;
      }
    }
    (*ordered)[best] = p;
    r->opencv.Add(bd);
    r->opencv_tilt[TiltBin(tilt)].Add(bd);
  }
  for (const auto& p : *ordered) {
    if (std::isnan(p.x)) return false;
  }
  return true;
}

// Renders the board in every pose and detects it with ours and OpenCV's finder (timed).
Detections DetectBoards(const StereoRig& rig, const CalibrationTarget& target,
                        const std::vector<Rigid3d>& poses, Result* r) {
  Detections d;
  sim::BoardRenderOptions ro;
  ro.sensor.read_noise_dn = 1.5;
  for (size_t i = 0; i < poses.size(); ++i) {
    const auto imgs = sim::RenderStereoBoard(rig, target, poses[i], ro, i);
    std::vector<cv::Point2f> ordered[2];
    bool ok_both = true;
    for (int cam = 0; cam < 2; ++cam) {
      const sim::BoardImage& bi = cam == 0 ? imgs.left : imgs.right;
      util::Timer t;
      auto det = calib::DetectTarget(bi.image, target);
      r->ours_ms += t.ElapsedMs();
      ++r->images;
      if (det.ok()) {
        ++r->ours_found;
      } else if (std::getenv("FRINGE_BENCH_VERBOSE")) {
        std::cerr << r->board << " pose " << i << " cam " << cam << ": " << det.BriefReport()
                  << "\n";
      }
      for (const auto& f : det.features) {
        r->ours_detect.Add((f.centre_px - bi.centres_px[f.row * target.cols + f.col]).norm());
      }
      (cam == 0 ? d.left : d.right).push_back(std::move(det));
      (cam == 0 ? d.truth_l : d.truth_r).push_back(bi.centres_px);
      t.Restart();
      std::vector<cv::Point2f> c;
      const bool found = OpenCvCircles(bi.image, target, &c);
      r->opencv_ms += t.ElapsedMs();
      if (!found) {
        ok_both = false;
        continue;
      }
      ++r->opencv_found;
      if (!OrderOpenCvCentres(c, bi, target, r, &ordered[cam])) ok_both = false;
    }
    d.cv_l.push_back(ordered[0]);
    d.cv_r.push_back(ordered[1]);
    d.cv_ok.push_back(ok_both);
  }
  r->ours_ms /= std::max(1, r->images);
  r->opencv_ms /= std::max(1, r->images);
  return d;
}

// Ours: joint stereo calibration (timed), final centres and parameters against the truth.
void CalibrateOurs(const StereoRig& rig, const CalibrationTarget& target,
                   const std::vector<Rigid3d>& poses, const Detections& d, Result* r) {
  util::Timer calib_timer;
  const double calib_cpu = bench::CpuMs();
  const auto cal = calib::CalibrateStereo(d.left, d.right, target, rig.left.width, rig.left.height);
  r->calib_ms = calib_timer.ElapsedMs();
  r->calib_cpu_ms = bench::CpuMs() - calib_cpu;
  if (std::getenv("FRINGE_BENCH_VERBOSE")) std::cerr << cal.BriefReport() << "\n";
  if (!cal.summary.ok()) return;
  r->rms_px = cal.rms_px;
  for (int cam = 0; cam < 2; ++cam) {
    const auto& cc = cam == 0 ? cal.left : cal.right;
    const auto& dets = cam == 0 ? d.left : d.right;
    const auto& truth = cam == 0 ? d.truth_l : d.truth_r;
    for (size_t v = 0; v < dets.size(); ++v) {
      const double tilt = TiltDeg(cam == 0 ? poses[v] : rig.right_from_left * poses[v]);
      for (size_t k = 0; k < cc.centres_px[v].size(); ++k) {
        const auto& f = dets[v].features[k];
        const double e = (cc.centres_px[v][k] - truth[v][f.row * target.cols + f.col]).norm();
        r->ours.Add(e);
        r->ours_tilt[TiltBin(tilt)].Add(e);
      }
    }
  }
  const auto& L = cal.rig.left;
  const auto& R = cal.rig.right;
  r->focal_err_pct = std::max({PctErr(L.fx, rig.left.fx), PctErr(L.fy, rig.left.fy),
                               PctErr(R.fx, rig.right.fx), PctErr(R.fy, rig.right.fy)});
  r->cxcy_err_px = std::max({std::abs(L.cx - rig.left.cx), std::abs(L.cy - rig.left.cy),
                             std::abs(R.cx - rig.right.cx), std::abs(R.cy - rig.right.cy)});
  r->k1_err = std::max(std::abs(L.k1 - rig.left.k1), std::abs(R.k1 - rig.right.k1));
  r->k2_err = std::max(std::abs(L.k2 - rig.left.k2), std::abs(R.k2 - rig.right.k2));
  r->baseline_err_mm = std::abs(cal.rig.BaselineMm() - rig.BaselineMm());
  r->angle_err_deg =
      Difference(cal.rig.right_from_left, rig.right_from_left).angle_rad * 180 / M_PI;
}

// OpenCV: calibrateCamera per camera then stereoCalibrate, complete pairs only.
void CalibrateOpenCv(const StereoRig& rig, const CalibrationTarget& target, const Detections& d,
                     Result* r) {
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> il, ir;
  std::vector<cv::Point3f> board;
  for (const auto& p : target.FeatureCentres()) board.emplace_back(p.x(), p.y(), 0.f);
  for (size_t v = 0; v < d.cv_ok.size(); ++v) {
    if (!d.cv_ok[v]) continue;
    obj.push_back(board);
    il.push_back(d.cv_l[v]);
    ir.push_back(d.cv_r[v]);
  }
  if (obj.size() < 3) return;
  const cv::Size size(rig.left.width, rig.left.height);
  cv::Mat k1, d1, k2, d2, rr, tt, e, f;
  std::vector<cv::Mat> rv, tv;
  const int flags = cv::CALIB_FIX_K3;
  util::Timer opencv_timer;
  const double opencv_cpu = bench::CpuMs();
  cv::calibrateCamera(obj, il, size, k1, d1, rv, tv, flags);
  cv::calibrateCamera(obj, ir, size, k2, d2, rv, tv, flags);
  r->opencv_rms_px = cv::stereoCalibrate(obj, il, ir, k1, d1, k2, d2, size, rr, tt, e, f,
                                         flags | cv::CALIB_USE_INTRINSIC_GUESS);
  r->opencv_calib_ms = opencv_timer.ElapsedMs();
  r->opencv_calib_cpu_ms = bench::CpuMs() - opencv_cpu;
  r->opencv_focal_err_pct = std::max(
      {PctErr(k1.at<double>(0, 0), rig.left.fx), PctErr(k1.at<double>(1, 1), rig.left.fy),
       PctErr(k2.at<double>(0, 0), rig.right.fx), PctErr(k2.at<double>(1, 1), rig.right.fy)});
  r->opencv_cxcy_err_px = std::max(
      {std::abs(k1.at<double>(0, 2) - rig.left.cx), std::abs(k1.at<double>(1, 2) - rig.left.cy),
       std::abs(k2.at<double>(0, 2) - rig.right.cx), std::abs(k2.at<double>(1, 2) - rig.right.cy)});
  r->opencv_k1_err =
      std::max(std::abs(d1.at<double>(0) - rig.left.k1), std::abs(d2.at<double>(0) - rig.right.k1));
  r->opencv_k2_err =
      std::max(std::abs(d1.at<double>(1) - rig.left.k2), std::abs(d2.at<double>(1) - rig.right.k2));
  Eigen::Matrix3d re;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) re(i, j) = rr.at<double>(i, j);
  }
  const Rigid3d rfl(re, Eigen::Vector3d(tt.at<double>(0), tt.at<double>(1), tt.at<double>(2)));
  r->opencv_baseline_err_mm = std::abs(rfl.translation().norm() - rig.BaselineMm());
  r->opencv_angle_err_deg = Difference(rfl, rig.right_from_left).angle_rad * 180 / M_PI;
}

Result RunBoard(const StereoRig& rig, const CalibrationTarget& target,
                const std::vector<Rigid3d>& poses) {
  Result r;
  r.board = TargetTypeName(target.type);
  r.ours_tilt.resize(kTiltBins);
  r.opencv_tilt.resize(kTiltBins);
  const Detections d = DetectBoards(rig, target, poses, &r);
  CalibrateOurs(rig, target, poses, d, &r);
  CalibrateOpenCv(rig, target, d, &r);
  return r;
}

json ToJson(const Result& r) {
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json bins = json::array();
  for (int b = 0; b < kTiltBins; ++b) {
    bins.push_back({{"tilt_deg", {b * kTiltBinDeg, (b + 1) * kTiltBinDeg}},
                    {"centre_rms_px", num(r.ours_tilt[b].Rms())},
                    {"centre_max_px", num(r.ours_tilt[b].max)},
                    {"features", r.ours_tilt[b].n},
                    {"opencv_centre_rms_px", num(r.opencv_tilt[b].Rms())},
                    {"opencv_centre_max_px", num(r.opencv_tilt[b].max)},
                    {"opencv_features", r.opencv_tilt[b].n}});
  }
  return {{"board", r.board},
          {"centre_rms_px", num(r.ours.Rms())},
          {"centre_max_px", num(r.ours.max)},
          {"detect_centre_rms_px", num(r.ours_detect.Rms())},
          {"opencv_centre_rms_px", num(r.opencv.Rms())},
          {"opencv_centre_max_px", num(r.opencv.max)},
          {"focal_err_pct", num(r.focal_err_pct)},
          {"opencv_focal_err_pct", num(r.opencv_focal_err_pct)},
          {"principal_err_px", num(r.cxcy_err_px)},
          {"opencv_principal_err_px", num(r.opencv_cxcy_err_px)},
          {"k1_err", num(r.k1_err)},
          {"opencv_k1_err", num(r.opencv_k1_err)},
          {"k2_err", num(r.k2_err)},
          {"opencv_k2_err", num(r.opencv_k2_err)},
          {"baseline_err_mm", num(r.baseline_err_mm)},
          {"opencv_baseline_err_mm", num(r.opencv_baseline_err_mm)},
          {"baseline_angle_err_deg", num(r.angle_err_deg)},
          {"opencv_baseline_angle_err_deg", num(r.opencv_angle_err_deg)},
          {"rms_px", num(r.rms_px)},
          {"opencv_rms_px", num(r.opencv_rms_px)},
          {"images", r.images},
          {"detection_rate", r.images ? double(r.ours_found) / r.images : 0.0},
          {"opencv_detection_rate", r.images ? double(r.opencv_found) / r.images : 0.0},
          {"ms_per_image", r.ours_ms},
          {"opencv_ms_per_image", r.opencv_ms},
          {"calibration_ms", num(r.calib_ms)},
          {"opencv_calibration_ms", num(r.opencv_calib_ms)},
          {"calibration_cpu_ms", num(r.calib_cpu_ms)},
          {"opencv_calibration_cpu_ms", num(r.opencv_calib_cpu_ms)},
          {"tilt_bins", bins}};
}

void PrintTable(const Result& r) {
  auto ratio = [](double a, double b) { return b != 0 ? a / b : NAN; };
  std::printf("\nboard: %s (%d images, both cameras)\n", r.board.c_str(), r.images);
  std::printf("%-28s %12s %12s %8s\n", "", "fringe", "OpenCV", "ratio");
  auto row = [&](const char* name, double a, double b) {
    std::printf("%-28s %12.5f %12.5f %8.3f\n", name, a, b, ratio(a, b));
  };
  row("centre RMS (px)", r.ours.Rms(), r.opencv.Rms());
  row("centre max (px)", r.ours.max, r.opencv.max);
  for (int b = 0; b < kTiltBins; ++b) {
    char name[64];
    std::snprintf(name, sizeof(name), "  centre RMS tilt %2.0f-%2.0f", b * kTiltBinDeg,
                  (b + 1) * kTiltBinDeg);
    row(name, r.ours_tilt[b].Rms(), r.opencv_tilt[b].Rms());
  }
  row("focal error (%)", r.focal_err_pct, r.opencv_focal_err_pct);
  row("principal point err (px)", r.cxcy_err_px, r.opencv_cxcy_err_px);
  row("k1 error", r.k1_err, r.opencv_k1_err);
  row("k2 error", r.k2_err, r.opencv_k2_err);
  row("baseline error (mm)", r.baseline_err_mm, r.opencv_baseline_err_mm);
  row("baseline angle err (deg)", r.angle_err_deg, r.opencv_angle_err_deg);
  row("reprojection RMS (px)", r.rms_px, r.opencv_rms_px);
  row("detection rate", r.images ? double(r.ours_found) / r.images : 0,
      r.images ? double(r.opencv_found) / r.images : 0);
  row("ms per image (detect)", r.ours_ms, r.opencv_ms);
  row("ms per stereo calibration", r.calib_ms, r.opencv_calib_ms);
  row("  CPU ms per calibration", r.calib_cpu_ms, r.opencv_calib_cpu_ms);
}

}  // namespace
}  // namespace fringe

int main(int argc, char** argv) {
  using namespace fringe;
  bool as_json = false;
  int count = 18;
  uint64_t seed = 5;
  CLI::App app("bench_calibration: board detection and stereo calibration, ours vs OpenCV");
  app.add_flag("--json", as_json, "Print one JSON object");
  app.add_option("--poses", count, "Board poses")
      ->check(CLI::Range(3, 1000))
      ->capture_default_str();
  app.add_option("--seed", seed, "Board pose seed")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  const StereoRig rig = StereoRig::Reference();
  const CalibrationTarget rings = CalibrationTarget::Reference();
  CalibrationTarget circles = rings;
  circles.type = TargetType::kCircleGrid;
  sim::BoardPoseOptions po;
  po.count = count;
  po.seed = seed;
  po.max_tilt_deg = 60;
  po.min_visible_fraction = 1.0;  // whole board in both cameras: OpenCV's finder needs it
  const std::vector<Rigid3d> poses = sim::GenerateBoardPoses(rig, rings, po);
  const Result rr = RunBoard(rig, rings, poses);
  const Result rc = RunBoard(rig, circles, poses);
  if (as_json) {
    json out = ToJson(rr);
    out["poses"] = count;
    out["circles"] = ToJson(rc);
    std::cout << out.dump() << "\n";
  } else {
    std::printf("bench_calibration: reference rig, %d poses (tilt 0-60 deg), read noise 1.5 DN\n",
                count);
    PrintTable(rr);
    PrintTable(rc);
  }
  return 0;
}
