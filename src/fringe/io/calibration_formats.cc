#include "fringe/io/calibration_formats.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>

#include "fringe/io/calibration_io.h"
#include "fringe/io/text_tree.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace {

namespace fs = std::filesystem;
using util::StrCat;

constexpr double kMmPerMetre = 1000.0;

std::string Names(const std::vector<fs::path>& paths) {
  std::string s;
  for (const auto& p : paths) s += (s.empty() ? "" : ", ") + p.string();
  return s;
}

// One parsed file (io/text_tree.h: yaml-cpp or tinyxml2 with limits; opencv_header: written by
// cv::FileStorage, so the opencv reader's spellings apply).
struct Loaded {
  fs::path path;
  TextTree tree;
  bool opencv_file = false;
};

std::vector<Loaded> Load(const std::vector<fs::path>& paths) {
  std::vector<Loaded> out;
  for (const fs::path& p : paths) {
    Loaded l;
    l.path = p;
    l.tree = ReadTextTree(p);
    l.opencv_file = l.tree.opencv_header;
    out.push_back(std::move(l));
  }
  return out;
}

bool Has(const Loaded& l, std::initializer_list<const char*> keys) {
  for (const char* k : keys) {
    if (!l.tree.root.Find(k)) return false;
  }
  return true;
}

bool Matches(CalibrationFormat f, const Loaded& l) {
  switch (f) {
    case CalibrationFormat::kSlStudio:
      return Has(l, {"Kc", "Kp", "Rp", "Tp"});
    case CalibrationFormat::kRos:
      return Has(l, {"camera_matrix", "rectification_matrix", "projection_matrix"});
    case CalibrationFormat::kKalibr: {
      const TextNode* cam0 = l.tree.root.Find("cam0");
      return cam0 && cam0->Find("intrinsics");
    }
    case CalibrationFormat::kOpenCv:
      if (!l.opencv_file) return false;
      for (const std::string& k : OpenCvCameraMatrixSpellings()) {
        if (l.tree.root.Find(k)) return true;
      }
      return false;
  }
  return false;
}

constexpr CalibrationFormat kFormats[] = {CalibrationFormat::kOpenCv, CalibrationFormat::kSlStudio,
                                          CalibrationFormat::kRos, CalibrationFormat::kKalibr};

std::vector<CalibrationFormat> Detect(const std::vector<Loaded>& files) {
  std::vector<CalibrationFormat> out;
  for (const CalibrationFormat f : kFormats) {
    for (const Loaded& l : files) {
      if (Matches(f, l)) {
        out.push_back(f);
        break;
      }
    }
  }
  return out;
}

// A value found under a key of one of the files.
struct Value {
  const Loaded* file = nullptr;
  std::string key;
  const TextNode* node = nullptr;
  std::string Where() const { return StrCat(file->path.string(), ": ", key); }
};

std::optional<Value> FindKey(const std::vector<Loaded>& files, const std::string& key) {
  std::optional<Value> found;
  for (const Loaded& l : files) {
    const TextNode* n = l.tree.root.Find(key);
    if (!n) continue;
    if (found) {
      throw Error(
          StrCat(key, " is in both ", found->file->path.string(), " and ", l.path.string()));
    }
    found = Value{&l, key, n};
  }
  return found;
}

std::vector<double> MatrixOf(const Value& v, const char* what, int rows = 0, int cols = 0) {
  std::string why;
  const std::optional<TextMatrix> m = ToMatrix(*v.node, &why);
  if (!m) throw Error(StrCat(v.Where(), " (", what, "): ", why));
  if ((rows > 0 && m->rows != rows) || (cols > 0 && m->cols != cols)) {
    throw Error(StrCat(v.Where(), " (", what, "): ", m->rows, "x", m->cols, ", expected ", rows,
                       "x", cols));
  }
  return m->data;
}

long long IntegerOf(const Value& v, const char* what) {
  const std::optional<long long> i = v.node->Integer();
  if (!i) throw Error(StrCat(v.Where(), " (", what, "): not an integer"));
  return *i;
}

// ---------------------------------------------------------------- explicit mapping, SLStudio --

// Width and height under `keys` (two integer keys, or one holding [w, h]); {0, 0} when the keys
// are not in the files. A present value of 0 (SLStudio's screenResX before a projector is set)
// counts as absent.
std::pair<int, int> SizeOf(const std::vector<Loaded>& files, const std::vector<std::string>& keys,
                           const char* what, OpenCvCalibration* out) {
  if (keys.size() == 1) {
    const auto v = FindKey(files, keys[0]);
    if (!v) return {0, 0};
    const std::vector<double> m = MatrixOf(*v, what);
    if (m.size() != 2 || m[0] != std::floor(m[0]) || m[1] != std::floor(m[1])) {
      throw Error(StrCat(v->Where(), " (", what, "): expected [width, height]"));
    }
    if (m[0] <= 0 || m[1] <= 0) return {0, 0};
    util::CheckRange(static_cast<long long>(m[0]), 1, util::kMaxImageSidePx, v->Where(), "width");
    util::CheckRange(static_cast<long long>(m[1]), 1, util::kMaxImageSidePx, v->Where(), "height");
    out->keys_used.push_back(StrCat(v->Where(), " -> ", what, " ", m[0], "x", m[1]));
    return {static_cast<int>(m[0]), static_cast<int>(m[1])};
  }
  const auto w = FindKey(files, keys.at(0)), h = FindKey(files, keys.at(1));
  if (!w || !h) return {0, 0};
  const long long wi = IntegerOf(*w, what), hi = IntegerOf(*h, what);
  if (wi <= 0 || hi <= 0) return {0, 0};
  util::CheckRange(wi, 1, util::kMaxImageSidePx, w->Where(), "width");
  util::CheckRange(hi, 1, util::kMaxImageSidePx, h->Where(), "height");
  out->keys_used.push_back(StrCat(w->Where(), " ", h->key, " -> ", what, " ", wi, "x", hi));
  return {static_cast<int>(wi), static_cast<int>(hi)};
}

std::optional<CameraModel> DeviceByKeys(const std::vector<Loaded>& files,
                                        const CalibrationKeyMap& map, const std::string& device,
                                        std::pair<int, int> size, OpenCvCalibration* out) {
  const std::vector<std::string>* keys = map.Find(device);
  if (!keys) return std::nullopt;
  const auto k = FindKey(files, keys->at(0));
  if (!k)
    throw Error(StrCat(Names({files[0].path}), ": no key ", keys->at(0), " (", device,
                       " camera matrix, as mapped)"));
  std::optional<Value> d;
  if (keys->size() > 1) {
    d = FindKey(files, keys->at(1));
    if (!d)
      throw Error(StrCat(k->file->path.string(), ": no key ", keys->at(1), " (", device,
                         " distortion, as mapped)"));
  }
  if (size.first <= 0) return std::nullopt;  // the caller notes the missing size
  const std::vector<double> km = MatrixOf(*k, "camera matrix");
  std::vector<double> dm;
  if (d) dm = MatrixOf(*d, "distortion");
  CameraModel c = CameraFromMatrices(km, d ? &dm : nullptr, size.first, size.second, device,
                                     k->Where(), d ? d->Where() : std::string());
  out->keys_used.push_back(StrCat(k->Where(), " -> ", device, " camera matrix"));
  if (d) out->keys_used.push_back(StrCat(d->Where(), " -> ", device, " distortion"));
  return c;
}

std::optional<Rigid3d> PoseByKeys(const std::vector<Loaded>& files, const CalibrationKeyMap& map,
                                  const std::string& target, OpenCvCalibration* out) {
  const std::vector<std::string>* keys = map.Find(target);
  if (!keys) return std::nullopt;
  const auto r = FindKey(files, keys->at(0)), t = FindKey(files, keys->at(1));
  if (!r || !t) {
    throw Error(StrCat(Names({files[0].path}), ": no key ", (r ? keys->at(1) : keys->at(0)), " (",
                       target, ", as mapped)"));
  }
  const Rigid3d pose = RigidFromMatrices(MatrixOf(*r, "rotation"), MatrixOf(*t, "translation"), 1.0,
                                         target, r->Where(), t->Where());
  out->keys_used.push_back(StrCat(r->Where(), " -> ", target, " rotation"));
  out->keys_used.push_back(StrCat(t->Where(), " -> ", target, " translation (mm)"));
  return pose;
}

OpenCvCalibration ReadByKeys(const std::vector<Loaded>& files, const CalibrationKeyMap& map,
                             const CalibrationReadOptions& o, const char* format) {
  OpenCvCalibration out;
  out.format = format;
  if (!map.Find("left")) {
    throw Error(
        StrCat(Names({files[0].path}), ": the key mapping names no left camera (left=K,D)"));
  }
  std::pair<int, int> size{0, 0};
  if (const auto* keys = map.Find("left_size")) size = SizeOf(files, *keys, "camera size", &out);
  if (size.first <= 0) {
    size = {o.camera_width, o.camera_height};
    if (size.first < 0) {
      // Description only (fringe info): twice the principal point stands in for the size.
      const auto k = FindKey(files, map.Find("left")->at(0));
      const std::vector<double> km =
          k ? MatrixOf(*k, "camera matrix", 3, 3) : std::vector<double>(9, 0.0);
      size = {std::max(1, static_cast<int>(std::lround(2 * km[2]))),
              std::max(1, static_cast<int>(std::lround(2 * km[5])))};
      out.keys_used.push_back(StrCat("image size not in the file; assumed ", size.first, "x",
                                     size.second,
                                     " (twice the principal point) for this "
                                     "description"));
    } else if (size.first == 0 || size.second == 0) {
      throw Error(StrCat(Names({files[0].path}),
                         ": the camera image size is not in the file and was not given"));
    } else {
      out.keys_used.push_back(
          StrCat("camera image size ", size.first, "x", size.second, " given (not in the file)"));
    }
  }
  out.left = DeviceByKeys(files, map, "left", size, &out);
  out.right = DeviceByKeys(files, map, "right", size, &out);
  std::pair<int, int> psize{0, 0};
  if (map.Find("projector")) {
    if (const auto* keys = map.Find("projector_size")) {
      psize = SizeOf(files, *keys, "projector size", &out);
    }
    if (psize.first <= 0 && o.projector_width > 0 && o.projector_height > 0) {
      psize = {o.projector_width, o.projector_height};
      out.keys_used.push_back(
          StrCat("projector size ", psize.first, "x", psize.second, " given (not in the file)"));
    }
    out.projector = DeviceByKeys(files, map, "projector", psize, &out);
    if (!out.projector) {
      out.keys_used.push_back("projector ignored: its size is not in the file and was not given");
    }
  }
  out.right_from_left = PoseByKeys(files, map, "right_from_left", &out);
  if (out.right_from_left && !out.right) {
    throw Error(StrCat(Names({files[0].path}), ": right_from_left mapped without a right camera"));
  }
  const std::optional<Rigid3d> pfl = PoseByKeys(files, map, "projector_from_left", &out);
  if (out.projector) {
    if (!pfl) {
      out.keys_used.push_back("projector ignored: no projector_from_left mapped");
      out.projector.reset();
    } else {
      out.projector_from_left = pfl;
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------- ROS --

struct RosCamera {
  CameraModel camera;
  Eigen::Matrix3d rect;   // rectification_matrix: rectified_from_camera
  std::vector<double> p;  // projection_matrix, 3x4 row-major
  const Loaded* file = nullptr;
};

RosCamera ReadRosCamera(const Loaded& l, const CalibrationReadOptions& o, OpenCvCalibration* out) {
  const std::vector<Loaded> one = {l};  // keys are looked up in this file alone
  const auto get = [&](const char* key) -> Value {
    const TextNode* n = l.tree.root.Find(key);
    if (!n) throw Error(StrCat(l.path.string(), ": no ", key, " (ROS camera_info)"));
    return Value{&l, key, n};
  };
  const std::string file = l.path.filename().string();
  int w = o.camera_width, h = o.camera_height;
  if (l.tree.root.Find("image_width") && l.tree.root.Find("image_height")) {
    const long long wi = IntegerOf(get("image_width"), "image width");
    const long long hi = IntegerOf(get("image_height"), "image height");
    util::CheckRange(wi, 1, util::kMaxImageSidePx, l.path.string(), "image_width");
    util::CheckRange(hi, 1, util::kMaxImageSidePx, l.path.string(), "image_height");
    w = static_cast<int>(wi);
    h = static_cast<int>(hi);
    out->keys_used.push_back(StrCat(file, ": image_width image_height -> image size ", w, "x", h));
  } else if (w <= 0 || h <= 0) {
    throw Error(StrCat(l.path.string(), ": no image_width / image_height and none given"));
  }
  const Value k = get("camera_matrix");
  const std::vector<double> km = MatrixOf(k, "camera matrix", 3, 3);
  std::vector<double> dm;
  std::optional<Value> d;
  if (const TextNode* n = l.tree.root.Find("distortion_coefficients")) {
    d = Value{&l, "distortion_coefficients", n};
    // ROS writes an empty list for a camera without distortion.
    const TextNode* data = n->Find("data");
    if (!(data && data->IsSeq() && data->items.empty())) dm = MatrixOf(*d, "distortion");
  }
  std::string model = "plumb_bob";
  if (const TextNode* m = l.tree.root.Find("distortion_model"); m && m->IsScalar()) {
    model = m->scalar;
  }
  if (model != "plumb_bob" && model != "rational_polynomial") {
    throw Error(StrCat(l.path.string(), ": distortion_model ", model,
                       ": fringe's lens model is plumb_bob (k1 k2 p1 p2 k3); rational_polynomial "
                       "is read when its extra terms are 0"));
  }
  RosCamera c;
  c.file = &l;
  c.camera = CameraFromMatrices(km, dm.empty() ? nullptr : &dm, w, h, file, k.Where(),
                                d ? d->Where() : std::string());
  const Value r = get("rectification_matrix");
  const std::vector<double> rm = MatrixOf(r, "rectification matrix", 3, 3);
  for (int i = 0; i < 9; ++i) c.rect(i / 3, i % 3) = rm[i];
  CheckRotationMatrix(c.rect, StrCat(r.Where(), " (rectification rotation)"));
  const Value p = get("projection_matrix");
  c.p = MatrixOf(p, "projection matrix", 3, 4);
  if (!(c.p[0] > 0) || !(c.p[5] > 0)) {
    throw Error(StrCat(p.Where(), ": the rectified focal lengths P[0][0], P[1][1] must be > 0"));
  }
  out->keys_used.push_back(StrCat(file, ": camera_matrix distortion_coefficients (", model,
                                  ") -> camera; rectification_matrix projection_matrix -> pose"));
  return c;
}

OpenCvCalibration ReadRos(const std::vector<Loaded>& files, const CalibrationReadOptions& o) {
  OpenCvCalibration out;
  out.format = "ros";
  if (files.size() > 2) {
    throw Error(StrCat(Names({files[0].path}),
                       ": ROS camera_info: one file per camera, at most two (left, right)"));
  }
  std::vector<RosCamera> cams;
  for (const Loaded& l : files) cams.push_back(ReadRosCamera(l, o, &out));
  const auto has_baseline = [](const RosCamera& c) { return c.p[3] != 0 || c.p[7] != 0; };
  if (cams.size() == 1) {
    // One camera: described alone (a rig needs the pair).
    if (has_baseline(cams[0])) {
      out.keys_used.push_back(
          "the right camera of a stereo pair (its projection_matrix holds a baseline); give the "
          "left camera's camera_info too for the pair");
    }
    out.left = cams[0].camera;
    return out;
  }
  if (has_baseline(cams[0]) == has_baseline(cams[1])) {
    throw Error(StrCat(Names({files[0].path, files[1].path}),
                       ": a stereo pair needs exactly one camera_info whose projection_matrix "
                       "holds the baseline (P[0][3] = -fx' B): the right camera"));
  }
  const RosCamera& left = has_baseline(cams[0]) ? cams[1] : cams[0];
  const RosCamera& right = has_baseline(cams[0]) ? cams[0] : cams[1];
  out.keys_used.push_back(StrCat(left.file->path.filename().string(), " -> left camera, ",
                                 right.file->path.filename().string(),
                                 " -> right camera (its projection_matrix holds the baseline)"));
  if (right.camera.width != left.camera.width || right.camera.height != left.camera.height) {
    throw Error(StrCat(Names({files[0].path, files[1].path}), ": the cameras' image sizes differ"));
  }
  // x_rect_right = x_rect_left + (Tx / fx', Ty / fy', 0) with Tx, Ty in metres times fx', fy'.
  const Eigen::Vector3d b_m(right.p[3] / right.p[0], right.p[7] / right.p[5], right.p[11]);
  if (right.p[11] != 0) {
    throw Error(StrCat(right.file->path.string(), ": projection_matrix P[2][3] must be 0"));
  }
  const Eigen::Matrix3d r = right.rect.transpose() * left.rect;
  out.left = left.camera;
  out.right = right.camera;
  out.right_from_left = Rigid3d(r, right.rect.transpose() * b_m * kMmPerMetre);
  out.keys_used.push_back("baseline from the right projection_matrix, metres -> mm");
  return out;
}

// ------------------------------------------------------------------------------- Kalibr --

struct KalibrCam {
  std::string name;
  CameraModel camera;
  Rigid3d from_previous;  // T_cn_cnm1 in mm
  bool projector_topic = false;
};

KalibrCam ReadKalibrCam(const Loaded& l, const std::string& name, const TextNode& n, bool first,
                        OpenCvCalibration* out) {
  const std::string where = StrCat(l.path.string(), ": ", name);
  const auto get = [&](const char* key) -> Value {
    const TextNode* v = n.Find(key);
    if (!v) throw Error(StrCat(where, ": no ", key));
    return Value{&l, StrCat(name, ".", key), v};
  };
  KalibrCam c;
  c.name = name;
  if (const TextNode* m = n.Find("camera_model"); m && m->scalar != "pinhole") {
    throw Error(StrCat(where, ".camera_model: ", m->scalar,
                       ": fringe's camera model is pinhole (with radtan distortion)"));
  }
  const Value res = get("resolution");
  const std::vector<double> r = MatrixOf(res, "resolution", 1, 2);
  if (r[0] != std::floor(r[0]) || r[1] != std::floor(r[1])) {
    throw Error(StrCat(res.Where(), ": resolution must be two integers"));
  }
  util::CheckRange(static_cast<long long>(r[0]), 1, util::kMaxImageSidePx, res.Where(), "width");
  util::CheckRange(static_cast<long long>(r[1]), 1, util::kMaxImageSidePx, res.Where(), "height");
  const Value in = get("intrinsics");
  const std::vector<double> i = MatrixOf(in, "intrinsics [fu fv pu pv]", 1, 4);
  const std::vector<double> k = {i[0], 0, i[2], 0, i[1], i[3], 0, 0, 1};
  std::string model = "radtan";
  if (const TextNode* m = n.Find("distortion_model"); m && m->IsScalar()) model = m->scalar;
  std::vector<double> d;
  if (model == "radtan") {
    d = MatrixOf(get("distortion_coeffs"), "distortion_coeffs [k1 k2 r1 r2]", 1, 4);
  } else if (model != "none") {
    throw Error(StrCat(where, ".distortion_model: ", model,
                       ": fringe's lens model is radtan (k1 k2 p1 p2 [k3]); recalibrate with it"));
  }
  c.camera = CameraFromMatrices(k, d.empty() ? nullptr : &d, static_cast<int>(r[0]),
                                static_cast<int>(r[1]), name, in.Where(),
                                StrCat(where, ".distortion_coeffs"));
  if (!first) {
    const Value t = get("T_cn_cnm1");
    const std::vector<double> m = MatrixOf(t, "T_cn_cnm1", 4, 4);
    if (m[12] != 0 || m[13] != 0 || m[14] != 0 || m[15] != 1) {
      throw Error(StrCat(t.Where(), ": the last row must be [0, 0, 0, 1]"));
    }
    c.from_previous =
        RigidFromMatrices({m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]},
                          {m[3], m[7], m[11]}, kMmPerMetre, "T_cn_cnm1", t.Where(), t.Where());
    out->keys_used.push_back(
        StrCat(t.Where(), " -> ", name, " from the previous camera (m -> mm)"));
  }
  if (const TextNode* topic = n.Find("rostopic"); topic && topic->IsScalar()) {
    c.projector_topic = topic->scalar.find("projector") != std::string::npos;
  }
  out->keys_used.push_back(StrCat(in.Where(), " ", name, ".distortion_coeffs (", model, ") ", name,
                                  ".resolution -> ", name));
  return c;
}

OpenCvCalibration ReadKalibr(const std::vector<Loaded>& files) {
  OpenCvCalibration out;
  out.format = "kalibr";
  if (files.size() != 1) {
    throw Error(StrCat(Names({files[0].path}), ": a Kalibr camchain is one file"));
  }
  const Loaded& l = files[0];
  std::vector<KalibrCam> cams;
  for (int n = 0;; ++n) {
    const TextNode* node = l.tree.root.Find(StrCat("cam", n));
    if (!node) break;
    if (n >= 3) {
      throw Error(
          StrCat(l.path.string(), ": cam3: fringe's rig holds two cameras and a projector"));
    }
    if (!node->IsMap()) throw Error(StrCat(l.path.string(), ": cam", n, " is not a mapping"));
    cams.push_back(ReadKalibrCam(l, StrCat("cam", n), *node, n == 0, &out));
  }
  // Every camera in cam0's frame (the left camera).
  std::vector<Rigid3d> from_cam0(cams.size());
  for (size_t n = 1; n < cams.size(); ++n) from_cam0[n] = cams[n].from_previous * from_cam0[n - 1];
  int projector = -1;
  for (size_t n = 0; n < cams.size(); ++n) {
    if (!cams[n].projector_topic) continue;
    if (n == 0) throw Error(StrCat(l.path.string(), ": cam0 must be a camera, not the projector"));
    if (projector >= 0) {
      throw Error(StrCat(l.path.string(), ": two cameras with a projector rostopic"));
    }
    projector = static_cast<int>(n);
  }
  if (projector < 0 && cams.size() == 3) projector = 2;
  out.left = cams[0].camera;
  out.keys_used.push_back("cam0 -> left camera");
  for (size_t n = 1; n < cams.size(); ++n) {
    if (static_cast<int>(n) == projector) {
      out.projector = cams[n].camera;
      out.projector_from_left = from_cam0[n];
      out.keys_used.push_back(
          StrCat(cams[n].name, " -> projector",
                 cams[n].projector_topic ? " (its rostopic says so)" : " (the third of three)"));
    } else {
      out.right = cams[n].camera;
      out.right_from_left = from_cam0[n];
      out.keys_used.push_back(StrCat(cams[n].name, " -> right camera"));
    }
  }
  if (out.right && (out.right->width != out.left->width || out.right->height != out.left->height)) {
    throw Error(StrCat(l.path.string(), ": the two cameras' resolutions differ"));
  }
  return out;
}

// ------------------------------------------------------------------------------ writers --

bool SingleCamera(const StereoRig& rig) { return rig.right_from_left.translation().norm() == 0; }

std::vector<double> KMatrix(const CameraModel& c) {
  return {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
}

Eigen::Matrix3d RotationOf(const Rigid3d& t) { return t.rotation().toRotationMatrix(); }

cv::Mat Mat(int rows, int cols, const std::vector<double>& v) {
  return cv::Mat(rows, cols, CV_64F, const_cast<double*>(v.data())).clone();
}
cv::Mat Mat(const Eigen::Matrix3d& m) {
  cv::Mat out(3, 3, CV_64F);
  for (int i = 0; i < 9; ++i) out.at<double>(i / 3, i % 3) = m(i / 3, i % 3);
  return out;
}
cv::Mat Mat(const Eigen::Vector3d& v) { return (cv::Mat_<double>(3, 1) << v[0], v[1], v[2]); }
cv::Mat Dist(const CameraModel& c) {
  const auto d = c.Distortion();
  return (cv::Mat_<double>(1, 5) << d[0], d[1], d[2], d[3], d[4]);
}

void RequireExtension(const fs::path& p, const std::vector<std::string>& ext, const char* format) {
  if (!util::HasExtension(p, ext)) {
    std::string list;
    for (const auto& e : ext) list += (list.empty() ? "" : " ") + e;
    throw Error(StrCat(p.string(), ": a ", format, " file must end in ", list));
  }
}

void WriteOpenCvStorage(util::OutputTransaction* tx, const fs::path& path,
                        const std::function<void(cv::FileStorage&)>& body) {
  tx->Write(path, [&](const fs::path& tmp) {
    cv::FileStorage fs(tmp.string(), cv::FileStorage::WRITE);
    if (!fs.isOpened()) throw Error(StrCat(tmp.string(), ": cannot write"));
    body(fs);
    fs.release();
  });
}

void EmitMatrix(YAML::Emitter& e, const char* key, int rows, int cols,
                const std::vector<double>& v) {
  e << YAML::Key << key << YAML::Value << YAML::BeginMap;
  e << YAML::Key << "rows" << YAML::Value << rows << YAML::Key << "cols" << YAML::Value << cols;
  e << YAML::Key << "data" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (const double x : v) e << x;
  e << YAML::EndSeq << YAML::EndMap;
}

void WriteYaml(util::OutputTransaction* tx, const fs::path& path, const YAML::Emitter& e) {
  if (!e.good()) throw Error(StrCat(path.string(), ": cannot format YAML: ", e.GetLastError()));
  tx->Write(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp);
    out << e.c_str() << "\n";
    util::CloseOutput(out, tmp);
  });
}

// ROS camera_info of one camera: rect = rectified_from_camera, baseline_m the right camera's
// distance from the left along the rectified x axis (0 for the left camera).
void EmitRosCamera(YAML::Emitter& e, const CameraModel& c, const std::string& name,
                   const Eigen::Matrix3d& rect, const CameraModel& rectified, double baseline_m) {
  e.SetDoublePrecision(17);
  e << YAML::BeginMap;
  e << YAML::Key << "image_width" << YAML::Value << c.width;
  e << YAML::Key << "image_height" << YAML::Value << c.height;
  e << YAML::Key << "camera_name" << YAML::Value << name;
  EmitMatrix(e, "camera_matrix", 3, 3, KMatrix(c));
  e << YAML::Key << "distortion_model" << YAML::Value << "plumb_bob";
  const auto d = c.Distortion();
  EmitMatrix(e, "distortion_coefficients", 1, 5, std::vector<double>(d.begin(), d.end()));
  std::vector<double> r(9);
  for (int i = 0; i < 9; ++i) r[i] = rect(i / 3, i % 3);
  EmitMatrix(e, "rectification_matrix", 3, 3, r);
  const double f = rectified.fy;  // square pixels after rectification
  EmitMatrix(e, "projection_matrix", 3, 4,
             {f, 0, rectified.cx, -f * baseline_m, 0, f, rectified.cy, 0, 0, 0, 1, 0});
  e << YAML::EndMap;
}

void EmitKalibrCam(YAML::Emitter& e, const std::string& name, const CameraModel& c,
                   const Rigid3d* from_previous, const std::string& topic) {
  e << YAML::Key << name << YAML::Value << YAML::BeginMap;
  if (from_previous) {
    const Eigen::Matrix3d r = RotationOf(*from_previous);
    const Eigen::Vector3d t = from_previous->translation() / kMmPerMetre;
    e << YAML::Key << "T_cn_cnm1" << YAML::Value << YAML::BeginSeq;
    for (int i = 0; i < 3; ++i) {
      e << YAML::Flow << YAML::BeginSeq << r(i, 0) << r(i, 1) << r(i, 2) << t[i] << YAML::EndSeq;
    }
    e << YAML::Flow << YAML::BeginSeq << 0.0 << 0.0 << 0.0 << 1.0 << YAML::EndSeq;
    e << YAML::EndSeq;
  }
  e << YAML::Key << "camera_model" << YAML::Value << "pinhole";
  e << YAML::Key << "intrinsics" << YAML::Value << YAML::Flow << YAML::BeginSeq << c.fx << c.fy
    << c.cx << c.cy << YAML::EndSeq;
  e << YAML::Key << "distortion_model" << YAML::Value << "radtan";
  e << YAML::Key << "distortion_coeffs" << YAML::Value << YAML::Flow << YAML::BeginSeq << c.k1
    << c.k2 << c.p1 << c.p2 << YAML::EndSeq;
  e << YAML::Key << "resolution" << YAML::Value << YAML::Flow << YAML::BeginSeq << c.width
    << c.height << YAML::EndSeq;
  e << YAML::Key << "rostopic" << YAML::Value << topic;
  e << YAML::EndMap;
}

}  // namespace

const char* CalibrationFormatName(CalibrationFormat format) {
  switch (format) {
    case CalibrationFormat::kOpenCv:
      return "opencv";
    case CalibrationFormat::kSlStudio:
      return "slstudio";
    case CalibrationFormat::kRos:
      return "ros";
    case CalibrationFormat::kKalibr:
      return "kalibr";
  }
  return "?";
}

CalibrationFormat ParseCalibrationFormat(const std::string& name) {
  for (const CalibrationFormat f : kFormats) {
    if (name == CalibrationFormatName(f)) return f;
  }
  throw Error(StrCat("calibration format '", name, "': expected opencv, slstudio, ros or kalibr"));
}

const std::vector<std::string>* CalibrationKeyMap::Find(const std::string& target) const {
  for (const auto& [t, keys] : entries) {
    if (t == target) return &keys;
  }
  return nullptr;
}

CalibrationKeyMap CalibrationKeyMap::Parse(const std::vector<std::string>& args) {
  // target -> (fewest, most) keys
  static const std::map<std::string, std::pair<size_t, size_t>> kTargets = {
      {"left", {1, 2}},
      {"right", {1, 2}},
      {"projector", {1, 2}},
      {"right_from_left", {2, 2}},
      {"projector_from_left", {2, 2}},
      {"left_size", {1, 2}},
      {"projector_size", {1, 2}}};
  CalibrationKeyMap map;
  for (const std::string& a : args) {
    const size_t eq = a.find('=');
    const std::string target = a.substr(0, eq);
    const auto it = kTargets.find(target);
    if (eq == std::string::npos || it == kTargets.end()) {
      throw Error(StrCat("--opencv-keys '", a,
                         "': expected TARGET=KEY[,KEY] with TARGET one of left, right, projector, "
                         "right_from_left, projector_from_left, left_size, projector_size"));
    }
    std::vector<std::string> keys;
    for (size_t b = eq + 1; b <= a.size();) {
      const size_t e = std::min(a.find(',', b), a.size());
      keys.push_back(a.substr(b, e - b));
      b = e + 1;
    }
    const bool empty_key = std::any_of(keys.begin(), keys.end(), [](auto& k) { return k.empty(); });
    if (empty_key || keys.size() < it->second.first || keys.size() > it->second.second) {
      throw Error(
          StrCat("--opencv-keys '", a, "': ", target, " takes ", it->second.first,
                 it->second.first == it->second.second ? "" : StrCat(" or ", it->second.second),
                 " non-empty key names"));
    }
    if (map.Find(target)) throw Error(StrCat("--opencv-keys: ", target, " given twice"));
    map.entries.emplace_back(target, keys);
  }
  return map;
}

CalibrationKeyMap SlStudioKeys() {
  return CalibrationKeyMap::Parse({"left=Kc,kc", "projector=Kp,kp", "projector_from_left=Rp,Tp",
                                   "left_size=frameWidth,frameHeight",
                                   "projector_size=screenResX,screenResY"});
}

std::vector<CalibrationFormat> DetectCalibrationFormats(const std::vector<fs::path>& files) {
  return Detect(Load(files));
}

OpenCvCalibration ReadCalibration(const std::vector<fs::path>& paths,
                                  const CalibrationReadOptions& o) {
  if (paths.empty()) throw Error("no calibration file given");
  const std::vector<Loaded> files = Load(paths);
  if (!o.keys.empty()) {
    OpenCvCalibration c = ReadByKeys(files, o.keys, o, "keys");
    return c;
  }
  const std::vector<CalibrationFormat> formats = Detect(files);
  if (formats.size() > 1) {
    std::string which;
    for (const CalibrationFormat f : formats) {
      which += StrCat(which.empty() ? "" : " and ", CalibrationFormatName(f));
    }
    throw Error(StrCat(Names(paths), ": matches the ", which,
                       " readers (each finds its keys); name the keys with --opencv-keys"));
  }
  const auto opencv = [&] {
    return ReadOpenCvKeySpellings(paths, o.camera_width, o.camera_height, o.projector_width,
                                  o.projector_height);
  };
  // Nothing recognised: the OpenCV reader, whose message lists the spellings it looked for.
  if (formats.empty()) return opencv();
  switch (formats[0]) {
    case CalibrationFormat::kOpenCv:
      return opencv();
    case CalibrationFormat::kSlStudio:
      return ReadByKeys(files, SlStudioKeys(), o, "slstudio");
    case CalibrationFormat::kRos:
      return ReadRos(files, o);
    case CalibrationFormat::kKalibr:
      return ReadKalibr(files);
  }
  return opencv();
}

OpenCvCalibration ReadOpenCvCalibration(const std::vector<fs::path>& files, int camera_width,
                                        int camera_height, int projector_width,
                                        int projector_height) {
  CalibrationReadOptions o;
  o.camera_width = camera_width;
  o.camera_height = camera_height;
  o.projector_width = projector_width;
  o.projector_height = projector_height;
  return ReadCalibration(files, o);
}

int CalibrationOutputCount(CalibrationFormat format) {
  return format == CalibrationFormat::kRos ? 2 : 1;
}

std::vector<std::string> WriteCalibration(CalibrationFormat format,
                                          const std::vector<fs::path>& outputs,
                                          const StereoRig& rig) {
  const int n = CalibrationOutputCount(format);
  if (static_cast<int>(outputs.size()) != n) {
    throw Error(StrCat(CalibrationFormatName(format), " calibration: ", n, " output file",
                       n == 1 ? "" : "s (left, right)", " expected, ", outputs.size(), " given"));
  }
  const bool single = SingleCamera(rig);
  std::vector<std::string> notes;
  util::OutputTransaction tx;
  switch (format) {
    case CalibrationFormat::kOpenCv: {
      RequireExtension(outputs[0], {".yml", ".yaml", ".xml"}, "OpenCV");
      if (!single && (rig.right.width != rig.left.width || rig.right.height != rig.left.height)) {
        throw Error(StrCat(outputs[0].string(),
                           ": OpenCV stereo files hold one image size; the cameras' differ"));
      }
      WriteOpenCvStorage(&tx, outputs[0], [&](cv::FileStorage& fs) {
        fs << "image_width" << rig.left.width << "image_height" << rig.left.height;
        fs << "M1" << Mat(3, 3, KMatrix(rig.left)) << "D1" << Dist(rig.left);
        if (!single) {
          fs << "M2" << Mat(3, 3, KMatrix(rig.right)) << "D2" << Dist(rig.right);
          fs << "R" << Mat(RotationOf(rig.right_from_left)) << "T"
             << Mat(rig.right_from_left.translation());
        }
        if (rig.projector) {
          fs << "projector_width" << rig.projector->width << "projector_height"
             << rig.projector->height;
          fs << "Kp" << Mat(3, 3, KMatrix(*rig.projector)) << "Dp" << Dist(*rig.projector);
          fs << "Rlp" << Mat(RotationOf(rig.projector_from_left)) << "Tlp"
             << Mat(rig.projector_from_left.translation());
        }
      });
      break;
    }
    case CalibrationFormat::kSlStudio: {
      RequireExtension(outputs[0], {".xml"}, "SLStudio calibration");
      if (!rig.projector) {
        throw Error(StrCat(outputs[0].string(),
                           ": SLStudio calibrates a camera and a projector; this rig has no "
                           "projector"));
      }
      if (!single) notes.push_back("slstudio: the right camera is not stored (SLStudio has one)");
      WriteOpenCvStorage(&tx, outputs[0], [&](cv::FileStorage& fs) {
        const CameraModel& p = *rig.projector;
        fs << "Kc" << Mat(3, 3, KMatrix(rig.left)) << "kc" << Dist(rig.left).t();
        fs << "Kp" << Mat(3, 3, KMatrix(p)) << "kp" << Dist(p).t();
        fs << "Rp" << Mat(RotationOf(rig.projector_from_left)) << "Tp"
           << Mat(rig.projector_from_left.translation());
        fs << "cam_error" << 0.0 << "proj_error" << 0.0 << "stereo_error" << 0.0;
        fs << "frameWidth" << rig.left.width << "frameHeight" << rig.left.height;
        fs << "screenResX" << p.width << "screenResY" << p.height;
      });
      break;
    }
    case CalibrationFormat::kRos: {
      if (single) {
        throw Error(StrCat(outputs[0].string(),
                           ": ROS camera_info describes a camera pair; this rig has one camera "
                           "and a projector (write kalibr, opencv or slstudio)"));
      }
      if (rig.projector)
        notes.push_back("ros: the projector is not stored (camera_info is cameras)");
      // Rectified frame: x along the baseline (left to right camera centre), y perpendicular to
      // it and to the left optical axis; both cameras keep the left's rectified intrinsics.
      const Eigen::Matrix3d r = RotationOf(rig.right_from_left);
      const Eigen::Vector3d centre = -(r.transpose() * rig.right_from_left.translation());
      const Eigen::Vector3d e1 = centre.normalized();
      Eigen::Vector3d e2 = Eigen::Vector3d::UnitZ().cross(e1);
      if (e2.norm() < 1e-9) {
        throw Error(StrCat(outputs[0].string(),
                           ": the baseline is along the optical axis: no rectification"));
      }
      e2.normalize();
      const Eigen::Vector3d e3 = e1.cross(e2);
      Eigen::Matrix3d rect_left;
      rect_left.row(0) = e1;
      rect_left.row(1) = e2;
      rect_left.row(2) = e3;
      const Eigen::Matrix3d rect_right = rect_left * r.transpose();
      const double baseline_m = centre.norm() / kMmPerMetre;
      YAML::Emitter left, right;
      EmitRosCamera(left, rig.left, "left", rect_left, rig.left, 0.0);
      EmitRosCamera(right, rig.right, "right", rect_right, rig.left, baseline_m);
      WriteYaml(&tx, outputs[0], left);
      WriteYaml(&tx, outputs[1], right);
      break;
    }
    case CalibrationFormat::kKalibr: {
      const auto radtan = [&](const CameraModel& c, const char* what) {
        if (c.k3 != 0) {
          throw Error(StrCat(outputs[0].string(), ": Kalibr's radtan model has no k3; the ", what,
                             " has k3 = ", c.k3));
        }
      };
      radtan(rig.left, "left camera");
      if (!single) radtan(rig.right, "right camera");
      if (rig.projector) radtan(*rig.projector, "projector");
      YAML::Emitter e;
      e.SetDoublePrecision(17);
      e << YAML::BeginMap;
      EmitKalibrCam(e, "cam0", rig.left, nullptr, "/cam0/image_raw");
      if (!single) EmitKalibrCam(e, "cam1", rig.right, &rig.right_from_left, "/cam1/image_raw");
      if (rig.projector) {
        const Rigid3d from_previous = single
                                          ? rig.projector_from_left
                                          : rig.projector_from_left * rig.right_from_left.Inverse();
        EmitKalibrCam(e, single ? "cam1" : "cam2", *rig.projector, &from_previous,
                      "/projector/image_raw");
      }
      e << YAML::EndMap;
      WriteYaml(&tx, outputs[0], e);
      break;
    }
  }
  tx.Commit();
  return notes;
}

}  // namespace fringe::io
