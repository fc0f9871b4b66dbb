#include "fringe/calib/calibrate_folder.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/log.h"

namespace fringe::calib {

namespace fs = std::filesystem;

namespace {

nlohmann::json ViewsJson(const CalibrationSummary& s) {
  nlohmann::json views = nlohmann::json::array();
  for (const auto& v : s.views) {
    views.push_back({{"name", v.name},
                     {"used", v.used},
                     {"features", v.num_features},
                     {"rms_px", v.rms_px},
                     {"max_px", v.max_px},
                     {"message", v.message}});
  }
  return views;
}

nlohmann::json StdJson(const CameraCalibration& c) {
  const char* names[kNumIntrinsics] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
  nlohmann::json j;
  for (int k = 0; k < kNumIntrinsics; ++k) j[names[k]] = c.std_dev[k];
  return j;
}

void AppendCamera(std::ostringstream& os, const char* label, const CameraCalibration& c) {
  const CameraModel& m = c.camera;
  os << std::fixed << std::setprecision(3);
  os << label << ": fx " << m.fx << " ± " << c.std_dev[0] << "  fy " << m.fy << " ± "
     << c.std_dev[1] << "  cx " << m.cx << " ± " << c.std_dev[2] << "  cy " << m.cy << " ± "
     << c.std_dev[3] << "\n";
  os << std::setprecision(5) << "  distortion k1 " << m.k1 << " k2 " << m.k2 << " p1 " << m.p1
     << " p2 " << m.p2 << " k3 " << m.k3 << "\n";
  os << std::setprecision(3) << "  " << c.summary.BriefReport() << "\n";
  // Coverage: fraction of a 8 x 8 grid of image cells containing a used feature.
  bool cell[8][8] = {};
  for (const auto& view : c.centres_px) {
    for (const auto& p : view) {
      const int i = std::clamp(static_cast<int>(8 * p.x() / m.width), 0, 7);
      const int j = std::clamp(static_cast<int>(8 * p.y() / m.height), 0, 7);
      cell[j][i] = true;
    }
  }
  int covered = 0;
  for (auto& row : cell) {
    for (bool b : row) covered += b ? 1 : 0;
  }
  os << "  image coverage " << covered * 100 / 64 << " % of 8x8 cells\n";
  for (const auto& v : c.summary.views) {
    os << "  " << std::left << std::setw(28) << v.name << std::right;
    if (v.used) {
      os << std::setw(4) << v.num_features << " features  RMS " << v.rms_px << " px  max "
         << v.max_px << " px\n";
    } else {
      os << " not used: " << v.message << "\n";
    }
  }
}

}  // namespace

std::string FolderCalibration::Report() const {
  std::ostringstream os;
  if (stereo) {
    AppendCamera(os, "left", pair.left);
    AppendCamera(os, "right", pair.right);
    const Rigid3d& t = pair.rig.right_from_left;
    os << std::fixed << std::setprecision(4) << "right_from_left: baseline "
       << pair.rig.BaselineMm() << " mm, rotation " << t.AngleRad() * 180 / M_PI << " deg, t = ("
       << t.translation().transpose() << ") mm\n";
    os << "joint: " << pair.BriefReport() << "\n";
  } else {
    AppendCamera(os, "camera", mono);
  }
  return os.str();
}

FolderCalibration CalibrateFolder(const fs::path& dir, const CalibrationTarget& target,
                                  const CalibrationOptions& options,
                                  const DetectionOptions& detection) {
  util::RequireDirectory(dir, "image folder");
  options.Check();
  detection.Check();
  FolderCalibration out;
  out.stereo = fs::is_directory(dir / "left") && fs::is_directory(dir / "right");
  const fs::path ldir = out.stereo ? dir / "left" : dir;
  out.names = io::ListImageFiles(ldir);
  if (out.names.empty()) throw Error(util::StrCat(ldir.string(), ": no images found"));
  if (out.stereo) {
    const auto rnames = io::ListImageFiles(dir / "right");
    if (rnames != out.names) {
      throw Error(util::StrCat(dir.string(),
                               ": left/ and right/ must hold images of the same "
                               "names (",
                               out.names.size(), " left, ", rnames.size(), " right)"));
    }
  }
  int width = 0, height = 0;
  util::Progress progress("detect", static_cast<int>(out.names.size()));
  for (const auto& name : out.names) {
    for (int cam = 0; cam < (out.stereo ? 2 : 1); ++cam) {
      const fs::path p = (out.stereo ? (cam == 0 ? dir / "left" : dir / "right") : dir) / name;
      const cv::Mat img = io::ReadGrayImage(
          p, width > 0 ? std::optional<cv::Size>(cv::Size(width, height)) : std::nullopt);
      width = img.cols;
      height = img.rows;
      (cam == 0 ? out.left : out.right).push_back(DetectTarget(img, target, detection));
    }
    progress.Advance();
  }
  // Warnings about the target's declaration (detect.h) hold for the whole folder: said once,
  // with how many images gave them, before the calibration's result or failure.
  std::map<std::string, int> warnings;
  for (const auto* views : {&out.left, &out.right}) {
    for (const TargetDetection& d : *views) {
      if (!d.warning.empty()) ++warnings[d.warning];
    }
  }
  const size_t images = out.left.size() + out.right.size();
  for (const auto& [text, count] : warnings) {
    util::LogWarning(util::StrCat(dir.string(), ": ", count, " of ", images, " images: ", text));
  }
  if (out.stereo) {
    out.pair = CalibrateStereo(out.left, out.right, target, width, height, options, out.names);
  } else {
    out.mono = CalibrateCamera(out.left, target, width, height, options, out.names);
  }
  return out;
}

nlohmann::json CalibrationToJson(const FolderCalibration& r) {
  if (r.stereo) {
    return {
        {"status", ToString(r.pair.summary.status)},
        {"message", r.pair.summary.message},
        {"rms_px", r.pair.rms_px},
        {"epipolar_rms_px", r.pair.epipolar_rms_px},
        {"epipolar_max_px", r.pair.epipolar_max_px},
        {"pairs", r.pair.num_pairs},
        {"std_dev", {{"left", StdJson(r.pair.left)}, {"right", StdJson(r.pair.right)}}},
        {"right_from_left_std_dev",
         {{"rotation_rad",
           {r.pair.extrinsic_std_dev[0], r.pair.extrinsic_std_dev[1], r.pair.extrinsic_std_dev[2]}},
          {"translation_mm",
           {r.pair.extrinsic_std_dev[3], r.pair.extrinsic_std_dev[4],
            r.pair.extrinsic_std_dev[5]}}}},
        {"views", ViewsJson(r.pair.summary)}};
  }
  return {{"status", ToString(r.mono.summary.status)},
          {"message", r.mono.summary.message},
          {"rms_px", r.mono.summary.final_rms_px},
          {"std_dev", StdJson(r.mono)},
          {"views", ViewsJson(r.mono.summary)}};
}

void WriteFolderCalibration(const fs::path& path, const FolderCalibration& r) {
  if (r.stereo) {
    nlohmann::json extra;
    extra["calibration"] = CalibrationToJson(r);
    io::WriteRig(path, r.pair.rig, extra);
  } else {
    nlohmann::json j = {{"format", "fringe-rig"},
                        {"version", 1},
                        {"units", "mm"},
                        {"camera", io::CameraToJson(r.mono.camera)}};
    j["calibration"] = CalibrationToJson(r);
    io::WriteJson(path, j);
  }
}

nlohmann::json CentresToJson(const FolderCalibration& r, const CalibrationTarget& target) {
  nlohmann::json rows = nlohmann::json::array();
  auto device = [&](const char* camera, const std::vector<TargetDetection>& views,
                    const CameraCalibration& cal) {
    for (size_t v = 0; v < views.size(); ++v) {
      const auto& features = views[v].features;
      // The calibration's centres are in detection order, for the views it used (empty else).
      const bool corrected =
          v < cal.centres_px.size() && cal.centres_px[v].size() == features.size() &&
          v < cal.residuals_px.size() && cal.residuals_px[v].size() == features.size();
      for (size_t k = 0; k < features.size(); ++k) {
        const FeatureObservation& f = features[k];
        nlohmann::json row = {{"camera", camera},
                              {"view", v},
                              {"name", v < r.names.size() ? r.names[v] : std::string()},
                              {"row", f.row},
                              {"col", f.col},
                              {"feature", f.row * target.cols + f.col},
                              {"raw_px", {f.centre_px.x(), f.centre_px.y()}},
                              {"corrected_px", nullptr},
                              {"residual_px", nullptr}};
        if (corrected) {
          const Eigen::Vector2d& c = cal.centres_px[v][k];
          const Eigen::Vector2d& e = cal.residuals_px[v][k];
          row["corrected_px"] = {c.x(), c.y()};
          row["residual_px"] = {e.x(), e.y()};
        }
        rows.push_back(std::move(row));
      }
    }
  };
  if (r.stereo) {
    device("left", r.left, r.pair.left);
    device("right", r.right, r.pair.right);
  } else {
    device("camera", r.left, r.mono);
  }
  return {{"format", "fringe-centres"}, {"version", 1}, {"units", "px"}, {"centres", rows}};
}

void CheckCentresPath(const fs::path& path) {
  const std::string ext = path.extension().string();
  if (ext != ".csv" && ext != ".json") {
    throw Error(util::StrCat(path.string(),
                             ": centres file must end in .csv or .json (the extension picks the "
                             "format)"));
  }
}

void WriteCentres(const fs::path& path, const FolderCalibration& r,
                  const CalibrationTarget& target) {
  CheckCentresPath(path);
  const nlohmann::json j = CentresToJson(r, target);
  if (path.extension() == ".json") {
    io::WriteJson(path, j);
    return;
  }
  std::ostringstream os;
  os << std::setprecision(10);
  os << "camera,view,name,row,col,feature,raw_x_px,raw_y_px,corrected_x_px,corrected_y_px,"
        "residual_x_px,residual_y_px\n";
  for (const auto& row : j["centres"]) {
    // Names are file names: quote them (CSV, RFC 4180) so commas cannot shift the columns.
    std::string name = row["name"].get<std::string>();
    std::string quoted = "\"";
    for (char c : name) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    quoted += '"';
    os << row["camera"].get<std::string>() << ',' << row["view"].get<int>() << ',' << quoted << ','
       << row["row"].get<int>() << ',' << row["col"].get<int>() << ',' << row["feature"].get<int>()
       << ',' << row["raw_px"][0].get<double>() << ',' << row["raw_px"][1].get<double>();
    for (const char* key : {"corrected_px", "residual_px"}) {
      if (row[key].is_null()) {
        os << ",,";
      } else {
        os << ',' << row[key][0].get<double>() << ',' << row[key][1].get<double>();
      }
    }
    os << '\n';
  }
  util::WriteAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << os.str();
    util::CloseOutput(out, path);
  });
}

cv::Mat ResidualImage(const CameraCalibration& cal, double scale) {
  const int w = cal.camera.width, h = cal.camera.height;
  if (!(scale > 0)) {
    // Auto: the RMS residual drawn as 1.5 % of the image width.
    double ss = 0;
    int n = 0;
    for (const auto& view : cal.residuals_px) {
      for (const auto& r : view) {
        ss += r.squaredNorm();
        ++n;
      }
    }
    const double rms = n ? std::sqrt(ss / n) : 1.0;
    scale = 0.015 * w / std::max(rms, 1e-6);
  }
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  for (const auto& view : cal.centres_px) {
    if (view.size() < 3) continue;
    std::vector<cv::Point> pts, hull;
    for (const auto& p : view) pts.emplace_back(cvRound(p.x()), cvRound(p.y()));
    cv::convexHull(pts, hull);
    cv::Mat layer = img.clone();
    cv::fillConvexPoly(layer, hull, cv::Scalar(200, 230, 200));
    cv::addWeighted(layer, 0.3, img, 0.7, 0, img);
  }
  for (size_t v = 0; v < cal.centres_px.size(); ++v) {
    for (size_t k = 0; k < cal.centres_px[v].size(); ++k) {
      const auto& p = cal.centres_px[v][k];
      const auto& r = cal.residuals_px[v][k];
      const cv::Point a(cvRound(p.x()), cvRound(p.y()));
      const cv::Point b(cvRound(p.x() + scale * r.x()), cvRound(p.y() + scale * r.y()));
      cv::circle(img, a, 2, cv::Scalar(0, 0, 0), cv::FILLED);
      cv::line(img, a, b, cv::Scalar(0, 0, 220), 1, cv::LINE_AA);
    }
  }
  cv::putText(img, util::StrCat("residuals x", std::lround(scale)), {10, 25},
              cv::FONT_HERSHEY_SIMPLEX, 0.7, cv::Scalar(0, 0, 0), 2);
  return img;
}

}  // namespace fringe::calib
