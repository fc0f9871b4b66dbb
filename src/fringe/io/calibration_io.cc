#include "fringe/io/calibration_io.h"

#include <algorithm>
#include <cmath>
#include <fstream>

#include "fringe/io/opencv_calibration.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace {

using nlohmann::json;
using util::StrCat;

double Number(const json& j, const char* key, const std::string& context) {
  return GetNumber(j, key, context);
}

int Integer(const json& j, const char* key, const std::string& context) {
  return static_cast<int>(GetInteger(j, key, 1, util::kMaxImageSidePx, context));
}

}  // namespace

void CheckPlausibleCamera(const CameraModel& c, const std::string& context) {
  // Finite but absurd values (fx = 1e300) overflow later arithmetic; no real lens comes near.
  const double side = std::max(c.width, c.height);
  if (!(c.fx <= 1e3 * side && c.fy <= 1e3 * side)) {
    throw Error(StrCat(context, ": focal length (", c.fx, ", ", c.fy, ") px is implausible for a ",
                       c.width, "x", c.height, " image"));
  }
  if (!(std::abs(c.cx) <= 1e2 * side && std::abs(c.cy) <= 1e2 * side)) {
    throw Error(StrCat(context, ": principal point (", c.cx, ", ", c.cy,
                       ") px is implausible for a ", c.width, "x", c.height, " image"));
  }
  for (double k : c.Distortion()) {
    if (!(std::abs(k) <= 1e4)) {
      throw Error(StrCat(context, ": distortion coefficient ", k, " is implausible"));
    }
  }
}

void CheckRotationMatrix(const Eigen::Matrix3d& m, const std::string& context) {
  if (!m.allFinite() || !((m * m.transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-6) ||
      !(m.determinant() > 0)) {
    throw Error(StrCat(context, ": not a rotation matrix (R R^T != I or det <= 0)"));
  }
}

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
  CheckKnownKeys(j, {"width", "height", "fx", "fy", "cx", "cy", "distortion", "distortion_model"},
                 context);
  if (j.contains("distortion_model") && j["distortion_model"] != "opencv_k1k2p1p2k3") {
    throw Error(StrCat(context, ".distortion_model: ", Brief(j["distortion_model"]),
                       ": only \"opencv_k1k2p1p2k3\" is supported"));
  }
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
      v[i] = AsNumber(d[i], StrCat(context, ".distortion[", i, "]"));
    }
    c.SetDistortion(v);
  }
  try {
    c.Check();
  } catch (const Error& e) {
    throw Error(StrCat(context, ": ", e.what()));
  }
  CheckPlausibleCamera(c, context);
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
  CheckKnownKeys(j, {"rotation", "translation_mm", "quaternion_wxyz"}, context);
  if (!j.contains("translation_mm") || !j["translation_mm"].is_array() ||
      j["translation_mm"].size() != 3) {
    throw Error(StrCat(context, ".translation_mm: expected [tx, ty, tz]"));
  }
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) {
    t[i] = AsNumber(j["translation_mm"][i], StrCat(context, ".translation_mm[", i, "]"));
  }
  // A kilometre is beyond any structured-light set-up: such a value is a unit mistake or a
  // hostile file, and would make every later computation meaningless.
  if (t.norm() > 1e6) {
    throw Error(StrCat(context, ".translation_mm: ", t.norm(), " mm is beyond 1 km"));
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
        m(i, k) = AsNumber(r[i][k], StrCat(context, ".rotation[", i, "][", k, "]"));
      }
    }
    CheckRotationMatrix(m, context + ".rotation");
    return Rigid3d(m, t);
  }
  if (j.contains("quaternion_wxyz")) {
    const json& q = j["quaternion_wxyz"];
    if (!q.is_array() || q.size() != 4) {
      throw Error(StrCat(context, ".quaternion_wxyz: expected [w, x, y, z]"));
    }
    const std::string qc = context + ".quaternion_wxyz";
    Eigen::Quaterniond quat(AsNumber(q[0], qc), AsNumber(q[1], qc), AsNumber(q[2], qc),
                            AsNumber(q[3], qc));
    if (!(std::abs(quat.norm() - 1.0) < 1e-3)) {
      throw Error(StrCat(qc, ": not a unit quaternion (norm ", quat.norm(), ")"));
    }
    return Rigid3d(quat.normalized(), t);
  }
  throw Error(StrCat(context, ": missing 'rotation' (or 'quaternion_wxyz')"));
}

json RigToJson(const StereoRig& rig) {
  json j{{"format", "fringe-rig"}, {"version", 1}, {"units", "mm"}};
  // A camera-projector rig (right = copy of left at zero baseline, as RigFromJson reads a file
  // without a right camera) is written without the copy.
  if (rig.projector && rig.BaselineMm() == 0 && rig.right == rig.left) {
    j["cameras"] = {{"left", CameraToJson(rig.left)}};
  } else {
    j["cameras"] = {{"left", CameraToJson(rig.left)}, {"right", CameraToJson(rig.right)}};
    j["right_from_left"] = RigidToJson(rig.right_from_left);
  }
  if (rig.projector) {
    j["cameras"]["projector"] = CameraToJson(*rig.projector);
    j["projector_from_left"] = RigidToJson(rig.projector_from_left);
  }
  return j;
}

StereoRig RigFromJson(const json& j, const std::string& context) {
  if (!j.is_object()) throw Error(StrCat(context, ": expected a JSON object"));
  if (!j.contains("format") || j["format"] != "fringe-rig") {
    throw Error(StrCat(context,
                       ": not a fringe rig file (\"format\": \"fringe-rig\" missing); give the "
                       "calibration with --calib RIG.json, or an OpenCV file with --opencv "
                       "(docs/formats.md)"));
  }
  // "calibration" carries the residuals and standard deviations fringe calibrate writes,
  // "refinement" the summary of fringe refine (pipeline/refine.h).
  CheckKnownKeys(j,
                 {"format", "version", "units", "cameras", "camera", "right_from_left",
                  "projector_from_left", "calibration", "refinement"},
                 context);
  OptionalInteger(j, "version", 1, 1, 1, context);
  if (OptionalString(j, "units", "mm", context) != "mm") {
    throw Error(StrCat(context, ".units: ", Brief(j["units"]), ": only \"mm\" is supported"));
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
  CheckKnownKeys(cams, {"left", "right", "projector"}, context + ".cameras");
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

StereoRig ReadRig(const std::filesystem::path& path) {
  return RigFromJson(ReadJson(path), path.string());
}

void WriteRig(const std::filesystem::path& path, const StereoRig& rig, const json& extra) {
  json j = RigToJson(rig);
  for (auto it = extra.begin(); it != extra.end(); ++it) j[it.key()] = it.value();
  WriteJson(path, j);
}

json TargetToJson(const CalibrationTarget& t) {
  json j{{"format", "fringe-target"},
         {"type", TargetTypeName(t.type)},
         {"rows", t.rows},
         {"cols", t.cols},
         {"spacing_mm", t.spacing_mm}};
  // Only the fields the type uses, so that the file reads back under the strict reader.
  if (t.type != TargetType::kChessboard) j["outer_radius_mm"] = t.outer_radius_mm;
  if (t.type == TargetType::kConcentricRings) {
    json distinct = json::array();
    for (const auto& [r, c] : t.distinct_features) distinct.push_back({r, c});
    j["inner_radius_mm"] = t.inner_radius_mm;
    j["distinct_features"] = distinct;
    if (!t.distinct_features.empty()) j["dot_radius_mm"] = t.dot_radius_mm;
  }
  j["margin_mm"] = t.margin_mm;
  return j;
}

CalibrationTarget TargetFromJson(const json& j, const std::string& context) {
  RequireObject(j, context);
  return WithJsonContext(context, [&] {
    if (j.contains("format") && j["format"] != "fringe-target") {
      throw Error(StrCat(context, ": not a fringe calibration target (\"format\" is ",
                         Brief(j["format"]), ", expected \"fringe-target\")"));
    }
    CheckKnownKeys(j,
                   {"format", "version", "type", "rows", "cols", "spacing_mm", "outer_radius_mm",
                    "inner_radius_mm", "dot_radius_mm", "distinct_features", "margin_mm"},
                   context);
    OptionalInteger(j, "version", 1, 1, 1, context);
    // The geometry is required: a default silently standing in for a misspelt field (a
    // "radius_mm" typo used to give the reference board's 8 mm) biases the calibration.
    CalibrationTarget t;
    t.type = TargetTypeFromName(GetString(j, "type", context));
    t.rows = static_cast<int>(GetInteger(j, "rows", 2, 1000, context));
    t.cols = static_cast<int>(GetInteger(j, "cols", 2, 1000, context));
    t.spacing_mm = GetNumber(j, "spacing_mm", context);
    const bool rings = t.type == TargetType::kConcentricRings;
    const bool chessboard = t.type == TargetType::kChessboard;
    if (!chessboard) t.outer_radius_mm = GetNumber(j, "outer_radius_mm", context);
    t.distinct_features.clear();
    if (rings) {
      t.inner_radius_mm = GetNumber(j, "inner_radius_mm", context);
      if (!j.contains("distinct_features")) {
        throw Error(StrCat(context,
                           ": missing field 'distinct_features' (the [row, col] of the rings "
                           "with a centre dot; [] when no ring is marked)"));
      }
      const json& list = j["distinct_features"];
      if (!list.is_array()) {
        throw Error(StrCat(context, ".distinct_features: expected [[row, col], ...]"));
      }
      for (size_t i = 0; i < list.size(); ++i) {
        const json& f = list[i];
        const std::string where = StrCat(context, ".distinct_features[", i, "]");
        if (!f.is_array() || f.size() != 2) throw Error(StrCat(where, ": expected [row, col]"));
        t.distinct_features.emplace_back(static_cast<int>(AsInteger(f[0], 0, t.rows - 1, where)),
                                         static_cast<int>(AsInteger(f[1], 0, t.cols - 1, where)));
      }
      if (!t.distinct_features.empty()) t.dot_radius_mm = GetNumber(j, "dot_radius_mm", context);
    } else {
      for (const char* key : {"inner_radius_mm", "dot_radius_mm", "distinct_features"}) {
        if (j.contains(key)) {
          throw Error(StrCat(context, ": '", key, "' applies to ring boards only (type is ",
                             TargetTypeName(t.type), ")"));
        }
      }
    }
    if (chessboard && j.contains("outer_radius_mm")) {
      throw Error(StrCat(context, ": 'outer_radius_mm' does not apply to a chessboard"));
    }
    t.margin_mm = OptionalNumber(j, "margin_mm", t.margin_mm, context);
    t.Check();
    return t;
  });
}

CalibrationTarget ReadTarget(const std::filesystem::path& path) {
  return TargetFromJson(ReadJson(path), path.string());
}

StereoRig ImportOpenCvStereo(const std::filesystem::path& intrinsics,
                             const std::filesystem::path& extrinsics, int width, int height) {
  return ReadOpenCvCalibration({intrinsics, extrinsics}, width, height)
      .ToRig(StrCat(intrinsics.string(), " + ", extrinsics.string()));
}

}  // namespace fringe::io
