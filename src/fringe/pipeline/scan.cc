#include "fringe/pipeline/scan.h"

#include <tbb/parallel_pipeline.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>

#include "fringe/calib/calibrate_folder.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/ply.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/stack_io.h"
#include "fringe/pipeline/report.h"
#include "fringe/registration/markers.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/log.h"
#include "fringe/util/memory.h"
#include "fringe/util/timer.h"

namespace fringe::pipeline {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using util::StrCat;

// Everything a reconstructed view hands to the later stages: its cloud (kept for registration
// and fusion; the images are gone) and the small pictures of the report.
struct ViewResult {
  ScanViewSummary summary;
  OrganizedPointCloud cloud;
  std::vector<registration::ViewMarker> markers;
  std::vector<ReportImage> pictures;
};

struct Calibration {
  StereoRig rig;
  std::string source;
  std::optional<calib::FolderCalibration> folder;  // when calibrated from board images here
};

std::string Fixed(double v, int digits) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(digits) << v;
  return os.str();
}

// The rig: options first, then PROJECT/rig.json, then PROJECT/calibration/ board images.
Calibration ResolveCalibration(const fs::path& project, const ScanOptions& options, int width,
                               int height) {
  Calibration c;
  if (!options.opencv_intrinsics.empty()) {
    c.rig =
        io::ImportOpenCvStereo(options.opencv_intrinsics, options.opencv_extrinsics, width, height);
    c.source = options.opencv_intrinsics.string() + " + " + options.opencv_extrinsics.string();
    return c;
  }
  if (!options.calib.empty()) {
    c.rig = io::ReadRig(options.calib);
    c.source = options.calib.string();
    return c;
  }
  if (fs::exists(project / "rig.json")) {
    c.rig = io::ReadRig(project / "rig.json");
    c.source = (project / "rig.json").string();
    return c;
  }
  const fs::path cal_dir = project / "calibration";
  if (!fs::is_directory(cal_dir)) {
    throw Error(StrCat("scan: ", project.string(),
                       ": no calibration: give --calib, or put rig.json or calibration/ board "
                       "images (with target.json) in the scan folder"));
  }
  util::RequireFile(cal_dir / "target.json", "calibration target");
  const CalibrationTarget target = io::ReadTarget(cal_dir / "target.json");
  util::LogInfo("scan: calibrating from " + cal_dir.string());
  calib::FolderCalibration cal = calib::CalibrateFolder(cal_dir, target);
  if (!cal.stereo) {
    throw Error(StrCat("scan: ", cal_dir.string(),
                       ": calibration: the images are of one camera; the scanner needs left/ and "
                       "right/ board images"));
  }
  if (!cal.success()) {
    throw Error(
        StrCat("scan: ", cal_dir.string(), ": calibration failed: ", cal.pair.summary.message));
  }
  c.rig = cal.pair.rig;
  c.source = StrCat(cal_dir.string(), " (", cal.names.size(), " board pairs)");
  c.folder = std::move(cal);
  return c;
}

// View folders PROJECT/views/*, in name order.
std::vector<std::string> DiscoverViews(const fs::path& project) {
  const fs::path dir = project / "views";
  util::RequireDirectory(dir, "scan views folder");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.is_directory()) names.push_back(e.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  if (names.empty()) throw Error(StrCat("scan: ", dir.string(), ": no view folders"));
  return names;
}

cv::Mat GridChannel(const OrganizedPointCloud& cloud, const std::vector<float>* attribute,
                    int axis) {
  cv::Mat m(cloud.height, cloud.width, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (int r = 0; r < cloud.height; ++r) {
    for (int c = 0; c < cloud.width; ++c) {
      const size_t i = cloud.index(c, r);
      if (!cloud.valid[i]) continue;
      m.at<float>(r, c) =
          attribute ? (*attribute)[i] : static_cast<float>(cloud.cloud.points[i][axis]);
    }
  }
  return m;
}

// The left texture image with the measured markers circled (their outer ring) and numbered.
cv::Mat TextureWithMarkers(const cv::Mat& texture_left,
                           const std::vector<registration::ViewMarker>& markers,
                           const StereoRig& rig, int max_width_px) {
  cv::Mat grey;
  texture_left.convertTo(grey, CV_8U);
  cv::Mat colour;
  cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
  const double scale = std::min(1.0, double(max_width_px) / colour.cols);
  if (scale < 1) cv::resize(colour, colour, cv::Size(), scale, scale, cv::INTER_AREA);
  for (const registration::ViewMarker& m : markers) {
    const cv::Point2d c(m.left_px.x() * scale, m.left_px.y() * scale);
    const double r_px = std::max(
        4.0, 1.5 * rig.left.fx * m.outer_radius_mm / std::max(1.0, m.centre_in_sensor.z()) * scale);
    cv::circle(colour, c, static_cast<int>(std::lround(r_px)), cv::Scalar(0, 0, 255), 2,
               cv::LINE_AA);
    cv::putText(colour, std::to_string(m.id), c + cv::Point2d(r_px, -r_px),
                cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 255, 255), 1, cv::LINE_AA);
  }
  return colour;
}

std::vector<ReportImage> ViewPictures(const std::string& name, const OrganizedPointCloud& cloud) {
  std::vector<ReportImage> out;
  const cv::Mat depth = GridChannel(cloud, nullptr, 2);
  const auto dr = DisplayRange(depth);
  out.push_back({StrCat("view ", name, ": depth (z in the sensor frame), mm"),
                 ColourMapWithBar(depth, dr[0], dr[1], "depth z, mm", 480)});
  if (cloud.cloud.has_quality()) {
    const cv::Mat modulation = GridChannel(cloud, &cloud.cloud.quality, 0);
    const auto mr = DisplayRange(modulation);
    out.push_back(
        {StrCat("view ", name, ": fringe modulation at measured points, DN"),
         ColourMapWithBar(modulation, std::max(0.0, mr[0]), mr[1], "modulation, DN", 480)});
  }
  return out;
}

// Reads, reconstructs and writes one view. Data failures come back in the summary (ok = false,
// the stage and the reason); nothing is thrown for them so that other views go on.
ViewResult ProcessView(const fs::path& project, const std::string& name,
                       const phase::PatternScheme& scheme, const StereoRig& rig,
                       const stereo::ViewReconstructor& reconstructor, const ScanOptions& options,
                       const fs::path& out_dir) {
  ViewResult v;
  ScanViewSummary& s = v.summary;
  s.name = name;
  const fs::path view_dir = project / "views" / name;
  std::string stage = "read";
  try {
    util::Timer timer;
    std::vector<cv::Mat> left, right;
    left = phase::ReadStack(view_dir / "left", scheme);
    right = phase::ReadStack(view_dir / "right", scheme);
    s.read_s = timer.ElapsedSeconds();
    stage = "reconstruct";
    stereo::ViewReconstruction rec = reconstructor.Reconstruct(left, right);
    left.clear();
    right.clear();
    s.decode_s = rec.summary.decode_s;
    s.reconstruct_s = rec.summary.total_s - rec.summary.decode_s;
    const double pixels = double(rec.cloud.width) * rec.cloud.height;
    s.decode_valid_left = rec.summary.decode_left.valid / std::max(1.0, pixels);
    s.decode_valid_right = rec.summary.decode_right.valid / std::max(1.0, pixels);
    if (!rec.summary.ok()) {
      throw Error(StrCat(view_dir.string(), ": ", stereo::ToString(rec.summary.status), ": ",
                         rec.summary.message));
    }
    s.points = rec.summary.points;
    s.valid_fraction = s.points / std::max(1.0, pixels);
    v.pictures = ViewPictures(name, rec.cloud);
    if (options.detect_markers) {
      stage = "markers";
      timer.Restart();
      registration::ViewMarkers markers = registration::DetectViewMarkers(
          rig, rec.texture_left, rec.texture_right, rec.cloud, options.markers);
      s.markers = static_cast<int>(markers.markers.size());
      v.markers = std::move(markers.markers);
      registration::WriteViewMarkers(out_dir / "views" / (name + ".markers.json"), v.markers);
      s.markers_s = timer.ElapsedSeconds();
    }
    v.pictures.push_back(
        {StrCat("view ", name, ": left texture (decoded fringe background) with the ", s.markers,
                " measured markers circled"),
         TextureWithMarkers(rec.texture_left, v.markers, rig, 480)});
    stage = "write";
    io::WritePly(out_dir / "views" / (name + ".ply"), rec.cloud, io::PlyFormat::kBinaryLittleEndian,
                 {StrCat("fringe scan: view ", name,
                         ", left camera (sensor) frame, mm; quality = fringe modulation (DN)")});
    v.cloud = std::move(rec.cloud);
    s.ok = true;
  } catch (const Error& e) {
    s.ok = false;
    s.failed_stage = stage;
    s.message = e.what();
  } catch (const cv::Exception& e) {
    s.ok = false;
    s.failed_stage = stage;
    s.message = StrCat(view_dir.string(), ": ", e.what());
  }
  return v;
}

ReportTable ViewTable(const std::vector<ScanViewSummary>& views) {
  ReportTable t;
  t.caption = "Views";
  t.header = {"view",         "status",        "points", "markers",  "measured px",
              "decoded left", "decoded right", "read s", "decode s", "reconstruct s"};
  for (const ScanViewSummary& v : views) {
    if (!v.ok) {
      t.rows.push_back({v.name, "FAILED in " + v.failed_stage + ": " + v.message, "", "", "", "",
                        "", Fixed(v.read_s, 3), Fixed(v.decode_s, 3), Fixed(v.reconstruct_s, 3)});
      continue;
    }
    t.rows.push_back({v.name, "ok", std::to_string(v.points), std::to_string(v.markers),
                      Fixed(100 * v.valid_fraction, 1) + " %",
                      Fixed(100 * v.decode_valid_left, 1) + " %",
                      Fixed(100 * v.decode_valid_right, 1) + " %", Fixed(v.read_s, 3),
                      Fixed(v.decode_s, 3), Fixed(v.reconstruct_s, 3)});
  }
  return t;
}

Report BuildReport(const fs::path& project, const ScanSummary& s, const Calibration& cal,
                   const std::vector<ViewResult>& views) {
  Report r;
  r.title = "fringe scan of " + project.filename().string();
  {
    ReportSection sec;
    sec.title = "Summary";
    sec.paragraphs.push_back(s.BriefReport());
    ReportTable t;
    t.caption = "Timings (read, decode and reconstruct are summed over views running in parallel)";
    t.header = {"stage", "seconds"};
    for (const auto& [name, value] : std::vector<std::pair<std::string, double>>{
             {"calibrate", s.calibrate_s},
             {"read images", s.read_s},
             {"decode fringes", s.decode_s},
             {"reconstruct", s.reconstruct_s},
             {"markers", s.markers_s},
             {"views (wall)", s.views_s},
             {"register", s.register_s},
             {"fuse", s.fuse_s},
             {"mesh", s.mesh_s},
             {"total (wall, without calibration)", s.total_s}}) {
      t.rows.push_back({name, Fixed(value, 3)});
    }
    sec.tables.push_back(t);
    ReportTable m;
    m.caption = "Result";
    m.header = {"figure", "value"};
    m.rows = {{"views measured", StrCat(s.views_ok, " of ", s.views.size())},
              {"points", std::to_string(s.points)},
              {"peak memory", Fixed(s.peak_mem_gib, 2) + " GiB"}};
    sec.tables.push_back(m);
    for (const ScanViewSummary& v : s.views) {
      if (!v.ok) {
        sec.paragraphs.push_back(StrCat("View ", v.name, " was left out: it failed in stage '",
                                        v.failed_stage, "': ", v.message));
      }
    }
    r.sections.push_back(std::move(sec));
  }
  {
    ReportSection sec;
    sec.title = "Calibration";
    sec.paragraphs.push_back("Rig from " + cal.source + ".");
    ReportTable t;
    t.header = {"figure", "left", "right"};
    t.rows.push_back(
        {"focal length fx, px", Fixed(cal.rig.left.fx, 2), Fixed(cal.rig.right.fx, 2)});
    t.rows.push_back({"image size, px", StrCat(cal.rig.left.width, " x ", cal.rig.left.height),
                      StrCat(cal.rig.right.width, " x ", cal.rig.right.height)});
    if (cal.folder) {
      t.rows.push_back({"reprojection RMS, px",
                        Fixed(cal.folder->pair.left.summary.final_rms_px, 4),
                        Fixed(cal.folder->pair.right.summary.final_rms_px, 4)});
    }
    sec.tables.push_back(t);
    sec.paragraphs.push_back("Baseline " + Fixed(cal.rig.BaselineMm(), 3) + " mm.");
    if (cal.folder) {
      sec.images.push_back({"left camera: residual vectors (magnified) and board coverage",
                            calib::ResidualImage(cal.folder->pair.left)});
      sec.images.push_back({"right camera: residual vectors (magnified) and board coverage",
                            calib::ResidualImage(cal.folder->pair.right)});
    }
    r.sections.push_back(std::move(sec));
  }
  {
    ReportSection sec;
    sec.title = "Views";
    sec.tables.push_back(ViewTable(s.views));
    for (const ViewResult& v : views) {
      for (const ReportImage& p : v.pictures) sec.images.push_back(p);
    }
    r.sections.push_back(std::move(sec));
  }
  return r;
}

}  // namespace

void ScanOptions::Check() const {
  util::CheckOption(views_in_flight >= 1 && views_in_flight <= 64, "ScanOptions", "views_in_flight",
                    views_in_flight, "must be in [1, 64]");
  util::CheckOption(opencv_intrinsics.empty() == opencv_extrinsics.empty(), "ScanOptions",
                    "opencv_intrinsics", opencv_intrinsics.string(),
                    "OpenCV intrinsics and extrinsics go together");
  util::CheckOption(calib.empty() || opencv_intrinsics.empty(), "ScanOptions", "calib",
                    calib.string(), "give a rig JSON or OpenCV files, not both");
  reconstruction.Check();
}

const char* ToString(ScanStatus s) {
  switch (s) {
    case ScanStatus::kOk:
      return "ok";
    case ScanStatus::kPartial:
      return "partial";
  }
  return "?";
}

std::string ScanSummary::BriefReport() const {
  std::string s =
      StrCat("scan: ", ToString(status), ", ", views_ok, " of ", views.size(), " views, ", points,
             " points in ", Fixed(total_s, 2), " s (read ", Fixed(read_s, 2), " s, decode ",
             Fixed(decode_s, 2), " s, reconstruct ", Fixed(reconstruct_s, 2),
             " s summed over views; "
             "views ",
             Fixed(views_s, 2), " s wall), peak memory ", Fixed(peak_mem_gib, 2), " GiB");
  if (!message.empty()) s += ": " + message;
  return s;
}

json ScanSummary::ToJson() const {
  json j{{"status", ToString(status)},
         {"message", message},
         {"calibration", calibration_source},
         {"views", views.size()},
         {"views_ok", views_ok},
         {"points", points},
         {"calibrate_s", calibrate_s},
         {"read_s", read_s},
         {"decode_s", decode_s},
         {"reconstruct_s", reconstruct_s},
         {"markers_s", markers_s},
         {"views_s", views_s},
         {"register_s", register_s},
         {"fuse_s", fuse_s},
         {"mesh_s", mesh_s},
         {"report_s", report_s},
         {"total_s", total_s},
         {"peak_mem_gib", peak_mem_gib}};
  if (calibration_rms_left_px > 0) {
    j["calibration_rms_left_px"] = calibration_rms_left_px;
    j["calibration_rms_right_px"] = calibration_rms_right_px;
  }
  json v = json::array();
  for (const ScanViewSummary& e : views) {
    json o{{"view", e.name},
           {"ok", e.ok},
           {"points", e.points},
           {"valid_fraction", e.valid_fraction},
           {"decode_valid_left", e.decode_valid_left},
           {"decode_valid_right", e.decode_valid_right},
           {"read_s", e.read_s},
           {"decode_s", e.decode_s},
           {"reconstruct_s", e.reconstruct_s},
           {"markers", e.markers},
           {"markers_s", e.markers_s}};
    if (!e.ok) {
      o["failed_stage"] = e.failed_stage;
      o["message"] = e.message;
    }
    v.push_back(o);
  }
  j["view_results"] = v;
  return j;
}

ScanSummary RunScan(const fs::path& project, const fs::path& out, const ScanOptions& options) {
  options.Check();
  util::RequireDirectory(project, "scan folder");
  // Inputs are checked before anything is computed: the scheme and the view list.
  util::RequireFile(project / "scheme.json", "pattern scheme manifest");
  const phase::PatternScheme scheme = phase::ReadScheme(project / "scheme.json");
  const std::vector<std::string> names = DiscoverViews(project);

  ScanSummary s;
  // The output folder must neither be the scan folder nor hold it (replacing it would delete the
  // user's images); checked before the work.
  util::OutputFolderOptions output;
  output.inputs = {project};
  if (!options.calib.empty()) output.inputs.push_back(options.calib);
  util::CheckOutputFolder(out, output);
  util::WriteFolderAtomically(out, output, [&](const fs::path& dir) {
    fs::create_directories(dir / "views");
    // 1. Calibration (its time is reported apart: a rig is calibrated once, not per scan).
    util::Timer timer;
    const cv::Mat first =
        io::ReadGrayImage(project / "views" / names.front() / "left" / scheme.ImageNames().front());
    const Calibration cal = ResolveCalibration(project, options, first.cols, first.rows);
    s.calibration_source = cal.source;
    if (cal.folder) {
      s.calibration_rms_left_px = cal.folder->pair.left.summary.final_rms_px;
      s.calibration_rms_right_px = cal.folder->pair.right.summary.final_rms_px;
      calib::WriteFolderCalibration(dir / "rig.json", *cal.folder);
    } else {
      io::WriteRig(dir / "rig.json", cal.rig);
    }
    s.calibrate_s = timer.ElapsedSeconds();

    // 2. Views, streamed: a serial source hands out view indices, at most views_in_flight are
    // read and reconstructed at once, results are stored by index (order-independent).
    util::Timer total;
    timer.Restart();
    const stereo::ViewReconstructor reconstructor(cal.rig, scheme, options.reconstruction);
    std::vector<ViewResult> results(names.size());
    {
      util::Progress progress("scan: reconstruct views", static_cast<int>(names.size()));
      size_t next = 0;
      tbb::parallel_pipeline(
          static_cast<size_t>(options.views_in_flight),
          tbb::make_filter<void, size_t>(tbb::filter_mode::serial_in_order,
                                         [&](tbb::flow_control& fc) -> size_t {
                                           if (next == names.size()) {
                                             fc.stop();
                                             return 0;
                                           }
                                           return next++;
                                         }) &
              tbb::make_filter<size_t, void>(tbb::filter_mode::parallel, [&](size_t i) {
                results[i] =
                    ProcessView(project, names[i], scheme, cal.rig, reconstructor, options, dir);
                progress.Advance();
              }));
    }
    s.views_s = timer.ElapsedSeconds();
    std::vector<std::string> failed, worked;
    for (const ViewResult& v : results) {
      s.views.push_back(v.summary);
      s.read_s += v.summary.read_s;
      s.decode_s += v.summary.decode_s;
      s.reconstruct_s += v.summary.reconstruct_s;
      s.markers_s += v.summary.markers_s;
      if (v.summary.ok) {
        ++s.views_ok;
        s.points += v.summary.points;
        worked.push_back(v.summary.name);
      } else {
        failed.push_back(StrCat("view ", v.summary.name, " failed in stage '",
                                v.summary.failed_stage, "': ", v.summary.message));
      }
    }
    if (!failed.empty()) {
      std::string list;
      for (const std::string& f : failed) list += (list.empty() ? "" : "; ") + f;
      if (!options.keep_going || worked.empty()) {
        std::string ok_list;
        for (const std::string& w : worked) ok_list += (ok_list.empty() ? "" : ", ") + w;
        throw Error(StrCat("scan: ", project.string(), ": ", list,
                           worked.empty() ? std::string("; no view worked")
                                          : StrCat("; views that worked: ", ok_list,
                                                   " (--keep-going finishes without the failed "
                                                   "ones)"),
                           "; nothing was written to ", out.string()));
      }
      s.status = ScanStatus::kPartial;
      s.message = StrCat(failed.size(), " view(s) left out: ", list);
      util::LogWarning(s.message);
    }

    // 4. Summary and report.
    s.total_s = total.ElapsedSeconds();
    s.peak_mem_gib = util::PeakMemoryGiB();
    if (options.write_report) {
      timer.Restart();
      BuildReport(project, s, cal, results).Write(dir / "report.html");
      s.report_s = timer.ElapsedSeconds();
      s.total_s = total.ElapsedSeconds();
    }
    io::WriteJson(dir / "summary.json", s.ToJson());
  });
  return s;
}

}  // namespace fringe::pipeline
