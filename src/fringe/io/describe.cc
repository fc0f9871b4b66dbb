#include "fringe/io/describe.h"

#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>

#include "fringe/io/calibration_io.h"
#include "fringe/io/opencv_calibration.h"
#include "fringe/io/ply.h"
#include "fringe/util/error.h"

namespace fringe::io {
namespace {

namespace fs = std::filesystem;
using util::StrCat;

std::string DescribePly(const fs::path& path) {
  const PlyData d = ReadPly(path);
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
  if (!d.cloud.empty()) {
    Eigen::Vector3d lo, hi;
    d.cloud.Bounds(&lo, &hi);
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
  const nlohmann::json j = ReadJson(path);
  std::ostringstream os;
  const std::string format = j.is_object() ? j.value("format", std::string()) : std::string();
  if (format == "fringe-rig" && j.contains("camera") && !j.contains("cameras")) {
    os << path.string() << ": single-camera calibration\n";
    os << "  camera:    " << DescribeCamera(CameraFromJson(j["camera"], path.string() + ": camera"))
       << "\n";
    return os.str();
  }
  if (format == "fringe-rig") {
    const StereoRig rig = RigFromJson(j, path.string());
    os << path.string() << ": rig calibration\n";
    os << "  left:      " << DescribeCamera(rig.left) << "\n";
    os << "  right:     " << DescribeCamera(rig.right) << "\n";
    os << std::fixed << std::setprecision(3) << "  baseline:  " << rig.BaselineMm()
       << " mm, angle between cameras " << rig.right_from_left.AngleRad() * 180 / M_PI << " deg\n";
    if (rig.projector) os << "  projector: " << DescribeCamera(*rig.projector) << "\n";
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

std::string DescribeFolder(const fs::path& path) {
  std::ostringstream os;
  os << path.string() << ": folder\n";
  // Scan folder layout (docs/formats.md): views/NNN/{left,right}/, calibration/{left,right}/.
  auto count_images = [](const fs::path& dir) {
    int n = 0;
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) return -1;
    for (const auto& e : fs::directory_iterator(dir)) {
      const std::string ext = e.path().extension().string();
      n += (ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".jpg" || ext == ".bmp");
    }
    return n;
  };
  std::error_code ec;
  if (fs::is_directory(path / "views", ec)) {
    std::map<std::string, std::pair<int, int>> views;
    for (const auto& e : fs::directory_iterator(path / "views")) {
      if (e.is_directory()) {
        views[e.path().filename().string()] = {count_images(e.path() / "left"),
                                               count_images(e.path() / "right")};
      }
    }
    os << "  views: " << views.size() << "\n";
    for (const auto& [name, c] : views) {
      os << "    " << name << ": left " << std::max(c.first, 0) << " images, right "
         << std::max(c.second, 0) << " images\n";
    }
  }
  for (const char* sub : {"calibration/left", "calibration/right", "left", "right"}) {
    const int n = count_images(path / sub);
    if (n >= 0) os << "  " << sub << ": " << n << " images\n";
  }
  for (const char* f : {"rig.json", "calibration.json", "truth/rig.json", "scheme.json"}) {
    if (fs::exists(path / f, ec)) os << "  " << f << "\n";
  }
  const int here = count_images(path);
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
    const OpenCvCalibration cv = ReadOpenCvCalibration({path}, -1, -1);
    return StrCat(path.string(), ": OpenCV calibration\n", cv.Describe());
  }
  throw Error(StrCat(path.string(),
                     ": unknown kind of file (expected .ply, .json, .yml/.yaml/.xml or a folder)"));
}

}  // namespace fringe::io
