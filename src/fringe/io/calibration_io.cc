#include "fringe/io/calibration_io.h"

#include <fstream>
#include <opencv2/core.hpp>

#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace {

using nlohmann::json;
using util::StrCat;

double Number(const json& j, const char* key, const std::string& context) {
  if (!j.contains(key)) throw Error(StrCat(context, ": missing field '", key, "'"));
  if (!j[key].is_number()) throw Error(StrCat(context, ".", key, ": expected a number"));
  return j[key].get<double>();
}

int Integer(const json& j, const char* key, const std::string& context) {
  if (!j.contains(key)) throw Error(StrCat(context, ": missing field '", key, "'"));
  if (!j[key].is_number_integer()) throw Error(StrCat(context, ".", key, ": expected an integer"));
  return j[key].get<int>();
}

}  // namespace

json CameraToJson(const CameraModel& c) {
  return json{{"width", c.width},
              {"height", c.height},
              {"fx", c.fx},
              {"fy", c.fy},
              {"cx", c.cx},
              {"cy", c.cy},
              {"distortion", {c.k1, c.k2, c.p1, c.p2, c.k3}},
              {"distortion_model", "opencv_k1k2p1p2k3"}};
}

CameraModel CameraFromJson(const json& j, const std::string& context) {
  if (!j.is_object()) throw Error(StrCat(context, ": expected an object"));
  CameraModel c;
  c.width = Integer(j, "width", context);
  c.height = Integer(j, "height", context);
  c.fx = Number(j, "fx", context);
  c.fy = Number(j, "fy", context);
  c.cx = Number(j, "cx", context);
  c.cy = Number(j, "cy", context);
  if (j.contains("distortion")) {
    const json& d = j["distortion"];
    if (!d.is_array() || d.size() < 4 || d.size() > 5) {
      throw Error(
          StrCat(context, ".distortion: expected [k1, k2, p1, p2] or [k1, k2, p1, p2, k3]"));
    }
    std::array<double, 5> v{0, 0, 0, 0, 0};
    for (size_t i = 0; i < d.size(); ++i) {
      if (!d[i].is_number())
        throw Error(StrCat(context, ".distortion[", i, "]: expected a number"));
      v[i] = d[i].get<double>();
    }
    c.SetDistortion(v);
  }
  try {
    c.Check();
  } catch (const Error& e) {
    throw Error(StrCat(context, ": ", e.what()));
  }
  return c;
}

json RigidToJson(const Rigid3d& t) {
  const Eigen::Matrix3d r = t.rotation_matrix();
  json rows = json::array();
  for (int i = 0; i < 3; ++i) rows.push_back({r(i, 0), r(i, 1), r(i, 2)});
  return json{{"rotation", rows},
              {"translation_mm", {t.translation().x(), t.translation().y(), t.translation().z()}}};
}

Rigid3d RigidFromJson(const json& j, const std::string& context) {
  if (!j.is_object()) throw Error(StrCat(context, ": expected an object"));
  if (!j.contains("translation_mm") || !j["translation_mm"].is_array() ||
      j["translation_mm"].size() != 3) {
    throw Error(StrCat(context, ".translation_mm: expected [tx, ty, tz]"));
  }
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) {
    if (!j["translation_mm"][i].is_number()) {
      throw Error(StrCat(context, ".translation_mm[", i, "]: expected a number"));
    }
    t[i] = j["translation_mm"][i].get<double>();
  }
  if (j.contains("rotation")) {
    const json& r = j["rotation"];
    Eigen::Matrix3d m;
    if (!r.is_array() || r.size() != 3) throw Error(StrCat(context, ".rotation: expected 3 rows"));
    for (int i = 0; i < 3; ++i) {
      if (!r[i].is_array() || r[i].size() != 3) {
        throw Error(StrCat(context, ".rotation[", i, "]: expected 3 numbers"));
      }
      for (int k = 0; k < 3; ++k) {
        if (!r[i][k].is_number()) throw Error(StrCat(context, ".rotation: expected numbers"));
        m(i, k) = r[i][k].get<double>();
      }
    }
    if (!((m * m.transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-6) ||
        !(m.determinant() > 0)) {
      throw Error(StrCat(context, ".rotation: not a rotation matrix (R R^T != I or det <= 0)"));
    }
    return Rigid3d(m, t);
  }
  if (j.contains("quaternion_wxyz")) {
    const json& q = j["quaternion_wxyz"];
    if (!q.is_array() || q.size() != 4) {
      throw Error(StrCat(context, ".quaternion_wxyz: expected [w, x, y, z]"));
    }
    Eigen::Quaterniond quat(q[0].get<double>(), q[1].get<double>(), q[2].get<double>(),
                            q[3].get<double>());
    if (!(quat.norm() > 0.5))
      throw Error(StrCat(context, ".quaternion_wxyz: not a unit quaternion"));
    return Rigid3d(quat.normalized(), t);
  }
  throw Error(StrCat(context, ": missing 'rotation' (or 'quaternion_wxyz')"));
}

json RigToJson(const StereoRig& rig) {
  json j{{"format", "fringe-rig"},
         {"version", 1},
         {"units", "mm"},
         {"cameras", {{"left", CameraToJson(rig.left)}, {"right", CameraToJson(rig.right)}}},
         {"right_from_left", RigidToJson(rig.right_from_left)}};
  if (rig.projector) {
    j["cameras"]["projector"] = CameraToJson(*rig.projector);
    j["projector_from_left"] = RigidToJson(rig.projector_from_left);
  }
  return j;
}

StereoRig RigFromJson(const json& j, const std::string& context) {
  if (!j.is_object()) throw Error(StrCat(context, ": expected a JSON object"));
  if (j.value("format", std::string()) != "fringe-rig") {
    throw Error(StrCat(context, ": not a fringe rig file (\"format\": \"fringe-rig\" missing)"));
  }
  if (j.contains("camera") && !j.contains("cameras")) {
    // A single-camera file (what `fringe calibrate` writes for one camera): the camera is
    // `left`; `right` is a copy at zero baseline, so a stereo consumer's rig.Check() refuses it.
    StereoRig rig;
    rig.left = CameraFromJson(j["camera"], context + ": camera");
    rig.right = rig.left;
    return rig;
  }
  if (!j.contains("cameras") || !j["cameras"].is_object()) {
    throw Error(StrCat(context, ": missing 'cameras' (or 'camera' for a single camera)"));
  }
  const json& cams = j["cameras"];
  StereoRig rig;
  if (!cams.contains("left")) throw Error(StrCat(context, ".cameras: missing 'left'"));
  rig.left = CameraFromJson(cams["left"], context + ": cameras.left");
  if (cams.contains("right")) {
    rig.right = CameraFromJson(cams["right"], context + ": cameras.right");
    if (!j.contains("right_from_left")) {
      throw Error(StrCat(context, ": has a right camera but no 'right_from_left'"));
    }
    rig.right_from_left = RigidFromJson(j["right_from_left"], context + ": right_from_left");
  } else {
    rig.right = rig.left;  // single-camera file: caller decides what to do with it
  }
  if (cams.contains("projector")) {
    rig.projector = CameraFromJson(cams["projector"], context + ": cameras.projector");
    if (!j.contains("projector_from_left")) {
      throw Error(StrCat(context, ": has a projector but no 'projector_from_left'"));
    }
    rig.projector_from_left =
        RigidFromJson(j["projector_from_left"], context + ": projector_from_left");
  }
  return rig;
}

json ReadJson(const std::filesystem::path& path) {
  const std::string text = util::ReadTextFile(path);
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    throw Error(StrCat(path.string(), ": invalid JSON: ", e.what()));
  }
}

void WriteJson(const std::filesystem::path& path, const json& j) {
  util::WriteAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp);
    out << j.dump(2) << "\n";
    out.close();
    if (!out) throw Error(StrCat(path.string(), ": write failed"));
  });
}

StereoRig ReadRig(const std::filesystem::path& path) {
  return RigFromJson(ReadJson(path), path.string());
}

void WriteRig(const std::filesystem::path& path, const StereoRig& rig, const json& extra) {
  json j = RigToJson(rig);
  for (auto it = extra.begin(); it != extra.end(); ++it) j[it.key()] = it.value();
  WriteJson(path, j);
}

json TargetToJson(const CalibrationTarget& t) {
  json distinct = json::array();
  for (const auto& [r, c] : t.distinct_features) distinct.push_back({r, c});
  return json{{"format", "fringe-target"},
              {"type", TargetTypeName(t.type)},
              {"rows", t.rows},
              {"cols", t.cols},
              {"spacing_mm", t.spacing_mm},
              {"outer_radius_mm", t.outer_radius_mm},
              {"inner_radius_mm", t.inner_radius_mm},
              {"dot_radius_mm", t.dot_radius_mm},
              {"distinct_features", distinct},
              {"margin_mm", t.margin_mm}};
}

CalibrationTarget TargetFromJson(const json& j, const std::string& context) {
  if (!j.is_object()) throw Error(StrCat(context, ": expected a JSON object"));
  return WithJsonContext(context, [&] {
    CalibrationTarget t;
    if (j.contains("type")) t.type = TargetTypeFromName(j["type"].get<std::string>());
    if (j.contains("rows")) t.rows = Integer(j, "rows", context);
    if (j.contains("cols")) t.cols = Integer(j, "cols", context);
    if (j.contains("spacing_mm")) t.spacing_mm = Number(j, "spacing_mm", context);
    if (j.contains("outer_radius_mm")) t.outer_radius_mm = Number(j, "outer_radius_mm", context);
    if (j.contains("inner_radius_mm")) t.inner_radius_mm = Number(j, "inner_radius_mm", context);
    if (j.contains("dot_radius_mm")) t.dot_radius_mm = Number(j, "dot_radius_mm", context);
    if (j.contains("margin_mm")) t.margin_mm = Number(j, "margin_mm", context);
    if (j.contains("distinct_features")) {
      t.distinct_features.clear();
      for (const json& f : j["distinct_features"]) {
        if (!f.is_array() || f.size() != 2) {
          throw Error(StrCat(context, ".distinct_features: expected [[row, col], ...]"));
        }
        t.distinct_features.emplace_back(f[0].get<int>(), f[1].get<int>());
      }
    }
    t.Check();
    return t;
  });
}

CalibrationTarget ReadTarget(const std::filesystem::path& path) {
  return TargetFromJson(ReadJson(path), path.string());
}

StereoRig ImportOpenCvStereo(const std::filesystem::path& intrinsics,
                             const std::filesystem::path& extrinsics, int width, int height) {
  util::RequireFile(intrinsics, "OpenCV intrinsics");
  util::RequireFile(extrinsics, "OpenCV extrinsics");
  auto read_mat = [](cv::FileStorage& fs, const char* name, const std::filesystem::path& file,
                     int rows, int min_cols) {
    cv::Mat m;
    fs[name] >> m;
    if (m.empty()) throw Error(StrCat(file.string(), ": missing matrix ", name));
    m.convertTo(m, CV_64F);
    if (static_cast<int>(m.total()) < rows * min_cols) {
      throw Error(StrCat(file.string(), ": matrix ", name, " has ", m.total(), " entries"));
    }
    return m.reshape(1, 1);
  };
  cv::FileStorage fi, fe;
  try {
    fi.open(intrinsics.string(), cv::FileStorage::READ);
    fe.open(extrinsics.string(), cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw Error(StrCat("cannot parse OpenCV calibration: ", e.what()));
  }
  if (!fi.isOpened()) throw Error(StrCat(intrinsics.string(), ": cannot parse as OpenCV YAML/XML"));
  if (!fe.isOpened()) throw Error(StrCat(extrinsics.string(), ": cannot parse as OpenCV YAML/XML"));
  auto camera = [&](const char* mname, const char* dname) {
    const cv::Mat k = read_mat(fi, mname, intrinsics, 3, 3);
    const cv::Mat d = read_mat(fi, dname, intrinsics, 1, 4);
    CameraModel c;
    c.width = width;
    c.height = height;
    c.fx = k.at<double>(0);
    c.cx = k.at<double>(2);
    c.fy = k.at<double>(4);
    c.cy = k.at<double>(5);
    std::array<double, 5> dist{0, 0, 0, 0, 0};
    for (int i = 0; i < std::min<int>(5, static_cast<int>(d.total())); ++i)
      dist[i] = d.at<double>(i);
    c.SetDistortion(dist);
    c.Check();
    return c;
  };
  StereoRig rig;
  rig.left = camera("M1", "D1");
  rig.right = camera("M2", "D2");
  const cv::Mat r = read_mat(fe, "R", extrinsics, 3, 3);
  const cv::Mat t = read_mat(fe, "T", extrinsics, 3, 1);
  Eigen::Matrix3d rm;
  for (int i = 0; i < 9; ++i) rm(i / 3, i % 3) = r.at<double>(i);
  rig.right_from_left =
      Rigid3d(rm, Eigen::Vector3d(t.at<double>(0), t.at<double>(1), t.at<double>(2)));
  return rig;
}

}  // namespace fringe::io
