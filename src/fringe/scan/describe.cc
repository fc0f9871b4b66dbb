#include "fringe/scan/describe.h"

#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>

#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/opencv_calibration.h"
#include "fringe/io/ply.h"
#include "fringe/phase/stack_io.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/util/error.h"

namespace fringe::scan {
namespace {

namespace fs = std::filesystem;
using util::StrCat;

std::string DescribePly(const fs::path& path) {
  const io::PlyData d = io::ReadPly(path);
  std::ostringstream os;
  os << path.string() << ": PLY (" << d.header.format << ")\n";
  for (const auto& e : d.header.elements) {
    os << "  element " << e.name << ": " << e.count << " (";
    for (size_t i = 0; i < e.properties.size(); ++i) {
      os << (i ? " " : "") << e.properties[i].name;
    }
    os << ")\n";
  }
  os << "  points: " << d.cloud.size() << (d.cloud.has_normals() ? ", normals" : "")
     << (d.cloud.has_colors() ? ", colours" : "") << (d.cloud.has_intensity() ? ", intensity" : "")
     << (d.cloud.has_quality() ? ", quality" : "") << "\n";
  if (!d.triangles.empty()) os << "  triangles: " << d.triangles.size() << "\n";
  // A body of garbage reads as numbers too: say what is not a coordinate instead of printing
  // bounds of NaN or 1e38. NaN vertices are also how other tools (PCL) keep an organized
  // cloud's invalid pixels, so a few are reported, not refused; a cloud of nothing else is.
  constexpr double kAbsurdMm = 1e9;  // a thousand kilometres: no measurement, in mm or m
  size_t non_finite = 0, absurd = 0;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3d& p : d.cloud.points) {
    if (!p.allFinite()) {
      ++non_finite;
    } else if (p.cwiseAbs().maxCoeff() > kAbsurdMm) {
      ++absurd;
    } else {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  const size_t bad = non_finite + absurd;
  if (!d.cloud.empty() && bad == d.cloud.size()) {
    throw Error(StrCat(path.string(), ": none of its ", d.cloud.size(),
                       " vertices is a usable point (", non_finite, " NaN or infinite, ", absurd,
                       " beyond 1e9 in magnitude): the body is damaged or is not point data"));
  }
  if (bad > 0) {
    os << "  damaged: " << non_finite << " vertices NaN or infinite, " << absurd
       << " beyond 1e9 in magnitude (not counted in the bounds)\n";
  }
  if (bad < d.cloud.size()) {
    os << std::fixed << std::setprecision(3) << "  bounds: [" << lo.transpose() << "] .. ["
       << hi.transpose() << "], size " << (hi - lo).transpose() << "\n";
  }
  if (d.header.grid_width > 0) {
    os << "  organized grid: " << d.header.grid_width << " x " << d.header.grid_height << ", "
       << d.cloud.size() << " valid (" << std::setprecision(1)
       << 100.0 * d.cloud.size() / (double(d.header.grid_width) * d.header.grid_height) << " %)\n";
  }
  return os.str();
}

std::string DescribeCamera(const CameraModel& c) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(3) << c.width << "x" << c.height << ", f = (" << c.fx
     << ", " << c.fy << ") px, c = (" << c.cx << ", " << c.cy
     << ") px, k1 k2 p1 p2 k3 = " << std::setprecision(6) << c.k1 << " " << c.k2 << " " << c.p1
     << " " << c.p2 << " " << c.k3;
  return os.str();
}

std::string DescribeJson(const fs::path& path) {
  const nlohmann::json j = io::ReadJson(path);
  std::ostringstream os;
  const std::string format = j.is_object() ? j.value("format", std::string()) : std::string();
  if (format == "fringe-rig" && j.contains("camera") && !j.contains("cameras")) {
    const StereoRig rig = io::RigFromJson(j, path.string());
    os << path.string() << ": single-camera calibration\n";
    os << "  camera:    " << DescribeCamera(rig.left) << "\n";
    if (j.contains("calibration") && j["calibration"].contains("rms_px")) {
      os << "  RMS reprojection error: " << j["calibration"]["rms_px"] << " px\n";
    }
    return os.str();
  }
  if (format == "fringe-rig") {
    const StereoRig rig = io::RigFromJson(j, path.string());
    // A file without a right camera (camera + projector) reads with right = left.
    const bool has_right = j.contains("cameras") && j["cameras"].contains("right");
    os << path.string() << ": rig calibration" << (has_right ? "" : " (camera + projector)")
       << "\n";
    os << "  left:      " << DescribeCamera(rig.left) << "\n";
    if (has_right) {
      os << "  right:     " << DescribeCamera(rig.right) << "\n";
      os << std::fixed << std::setprecision(3) << "  baseline:  " << rig.BaselineMm()
         << " mm, angle between cameras " << rig.right_from_left.AngleRad() * 180 / M_PI
         << " deg\n";
    }
    if (rig.projector) {
      os << "  projector: " << DescribeCamera(*rig.projector) << "\n";
      os << std::fixed << std::setprecision(3)
         << "  camera-projector baseline: " << rig.projector_from_left.translation().norm()
         << " mm, angle " << rig.projector_from_left.AngleRad() * 180 / M_PI << " deg\n";
    }
    return os.str();
  }
  os << path.string() << ": JSON" << (format.empty() ? "" : " (" + format + ")") << "\n";
  if (j.is_object()) {
    os << "  keys:";
    for (auto it = j.begin(); it != j.end(); ++it) os << " " << it.key();
    os << "\n";
  }
  return os.str();
}

std::string DescribeScanFolder(const ScanFolder& scan) {
  const ScanManifest& m = scan.manifest();
  std::ostringstream os;
  os << scan.root().string() << ": scan folder"
     << (m.generator.empty()
             ? ""
             : " (" + m.generator + (m.scene.empty() ? "" : ", scene " + m.scene) + ")")
     << "\n";
  if (scan.inferred()) {
    os << "  manifest: inferred (no scan.json; `fringe info " << scan.root().string()
       << " --init` writes it)\n";
    for (const std::string& n : scan.inferred_notes()) os << "    " << n << "\n";
  }
  os << "  images: " << m.image_width << "x" << m.image_height << ", " << m.bit_depth << "-bit\n";
  os << "  views: " << scan.views().size();
  if (scan.has_views()) {
    os << " (" << scan.views().front() << " .. " << scan.views().back() << "), scheme " << m.scheme;
  }
  os << "\n";
  if (!scan.stereo()) {
    os << "  one camera + projector (views hold left/ only"
       << (scan.both_directions()
               ? "; both fringe directions, horizontal scheme " + m.scheme_horizontal
               : std::string())
       << ")\n";
  }
  // Images of a stack folder, or of its exposure folders e0/, e1/, ...
  const auto images = [](const fs::path& dir) {
    if (!phase::HasExposureFolders(dir)) {
      return StrCat(io::ListImageFiles(dir).size(), " images");
    }
    size_t n = 0;
    int exposures = 0;
    for (; fs::is_directory(phase::ExposureDir(dir, exposures)); ++exposures) {
      n += io::ListImageFiles(phase::ExposureDir(dir, exposures)).size();
    }
    return StrCat(n, " images in ", exposures, " exposures");
  };
  for (const std::string& v : scan.views()) {
    os << "    " << v << ": left ";
    if (scan.both_directions()) {
      os << "vertical " << images(scan.StackDir(v, Camera::kLeft, 0)) << ", horizontal "
         << images(scan.StackDir(v, Camera::kLeft, 1));
    } else {
      os << images(scan.layout().CameraDir(v, Camera::kLeft));
    }
    if (scan.stereo()) os << ", right " << images(scan.layout().CameraDir(v, Camera::kRight));
    os << "\n";
  }
  os << "  calibration: " << m.calibration_images
     << (scan.stereo() ? " board images per camera" : " board pose folders");
  if (scan.has_calibration()) os << ", target " << m.calibration_target;
  os << "\n";
  os << "  truth: " << (scan.has_truth() ? m.truth + "/" : "none") << "\n";
  return os.str();
}

// A folder that is not a scan folder: image counts of the usual sub-folders of a capture.
std::string DescribeFolder(const fs::path& path) {
  std::error_code ec;
  // A scan folder, or a folder of views another tool wrote (its manifest is inferred).
  if (ScanFolder::IsScanFolder(path) ||
      (fs::is_directory(path / "views", ec) && fs::is_regular_file(path / "scheme.json", ec))) {
    return DescribeScanFolder(ScanFolder::Open(path));
  }
  std::ostringstream os;
  os << path.string() << ": folder (no scan.json: not a scan folder)\n";
  for (const char* sub : {"left", "right", "L", "R", "calibration/left", "calibration/right"}) {
    if (fs::is_directory(path / sub, ec)) {
      os << "  " << sub << ": " << io::ListImageFiles(path / sub).size() << " images\n";
    }
  }
  for (const char* f : {"rig.json", "calibration.json", "scheme.json", "manifest.json"}) {
    if (fs::exists(path / f, ec)) os << "  " << f << "\n";
  }
  const size_t here = io::ListImageFiles(path).size();
  if (here > 0) os << "  images: " << here << "\n";
  return os.str();
}

}  // namespace

std::string DescribePath(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error(StrCat(path.string(), ": no such file or folder"));
  if (fs::is_directory(path, ec)) return DescribeFolder(path);
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".ply") return DescribePly(path);
  if (ext == ".json") return DescribeJson(path);
  if (ext == ".yml" || ext == ".yaml" || ext == ".xml") {
    const io::OpenCvCalibration cv = io::ReadOpenCvCalibration({path}, -1, -1);
    // Which tool's file it is (io/calibration_formats.h detects it).
    const std::string kind = cv.format == "slstudio" ? "SLStudio calibration"
                             : cv.format == "ros"    ? "ROS camera_info"
                             : cv.format == "kalibr" ? "Kalibr camchain"
                                                     : "OpenCV calibration";
    const std::string text = StrCat(path.string(), ": ", kind, "\n", cv.Describe());
    // What reconstruct and convert-calib would refuse (distortion longer than fringe's model, a
    // bad rotation) is an error here too, not a description of something unusable.
    if (cv.right && cv.right_from_left) {
      (void)cv.ToRig(path.string());
    } else if (cv.projector) {
      (void)cv.ToCameraProjectorRig(path.string());
    }
    return text;
  }
  throw Error(StrCat(path.string(),
                     ": unknown kind of file (expected .ply, .json, .yml/.yaml/.xml or a folder)"));
}

}  // namespace fringe::scan
