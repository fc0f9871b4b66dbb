#include "fringe/io/opencv_calibration.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <string_view>

#include "fringe/io/calibration_io.h"
#include "fringe/io/text_tree.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace {

namespace fs = std::filesystem;
using util::StrCat;

// Key spellings, most common first. Matched exactly (OpenCV keys are case sensitive).
const std::vector<std::string> kLeftK = {"M1",
                                         "K1",
                                         "cameraMatrix1",
                                         "cameraMatrixL",
                                         "camera_matrix_left",
                                         "cameraMatrixLeft",
                                         "K_left",
                                         "KL",
                                         "Kl",
                                         "M_l",
                                         "leftCameraMatrix",
                                         "camera_matrix",
                                         "cameraMatrix",
                                         "K"};
const std::vector<std::string> kLeftD = {"D1",
                                         "distCoeffs1",
                                         "distCoeffsL",
                                         "dist_coeffs_left",
                                         "distCoeffsLeft",
                                         "D_left",
                                         "DL",
                                         "Dl",
                                         "D_l",
                                         "leftDistCoeffs",
                                         "distortion_coefficients",
                                         "dist_coeffs",
                                         "distCoeffs",
                                         "D"};
const std::vector<std::string> kRightK = {"M2",
                                          "K2",
                                          "cameraMatrix2",
                                          "cameraMatrixR",
                                          "camera_matrix_right",
                                          "cameraMatrixRight",
                                          "K_right",
                                          "KR",
                                          "Kr",
                                          "M_r",
                                          "rightCameraMatrix"};
const std::vector<std::string> kRightD = {
    "D2", "distCoeffs2", "distCoeffsR", "dist_coeffs_right", "distCoeffsRight", "D_right",
    "DR", "Dr",          "D_r",         "rightDistCoeffs"};
const std::vector<std::string> kProjK = {"M3",
                                         "M4",
                                         "K3",
                                         "K4",
                                         "Kp",
                                         "K_p",
                                         "KP",
                                         "Mp",
                                         "projectorMatrix",
                                         "cameraMatrixP",
                                         "camera_matrix_projector",
                                         "projector_matrix",
                                         "K_projector",
                                         "projectorCameraMatrix"};
const std::vector<std::string> kProjD = {"D3",          "D4",
                                         "Dp",          "D_p",
                                         "DP",          "projectorDistCoeffs",
                                         "distCoeffsP", "dist_coeffs_projector",
                                         "D_projector"};
const std::vector<std::string> kRightR = {"R", "Rlr", "R_l2r", "R_lr", "R12", "Rl2r", "R_LR"};
const std::vector<std::string> kRightT = {"T", "Tlr", "T_l2r", "T_lr", "T12", "Tl2r", "T_LR"};
const std::vector<std::string> kProjR = {"Rlp",  "R_l2p", "R_lp", "R13",
                                         "Rl2p", "R_LP",  "Rp",   "R_p"};
const std::vector<std::string> kProjT = {"Tlp",  "T_l2p", "T_lp", "T13",
                                         "Tl2p", "T_LP",  "Tp",   "T_p"};

// A value found in one of the files.
struct Found {
  fs::path file;
  std::string key;
  std::vector<double> m;  // the matrix's values, row-major
};

// The files parsed by yaml-cpp / tinyxml2 with explicit limits (io/text_tree.h); OpenCV's own
// parser is never given an untrusted file (it allocated from declared sizes, looped and crashed
// on files fuzzing made).
class Files {
 public:
  explicit Files(const std::vector<fs::path>& paths) {
    for (const fs::path& p : paths) trees_.push_back(ReadTextTree(p));
  }

  // The first spelling present in any file; an error when two files (or two spellings) hold it.
  std::optional<Found> Matrix(const std::vector<std::string>& spellings, const char* what) const {
    std::optional<Found> found;
    for (const TextTree& tree : trees_) {
      for (const std::string& key : spellings) {
        const TextNode* node = tree.root.Find(key);
        if (node == nullptr || node->kind == TextNode::Kind::kNull) continue;
        if (found) {
          throw Error(StrCat(tree.path.string(), ": ", key, " and ", found->file.string(), ": ",
                             found->key, " both give the ", what,
                             "; keep one (fringe will not guess)"));
        }
        std::string why;
        std::optional<TextMatrix> m;
        if (node->IsMap() || node->IsSeq()) m = ToMatrix(*node, &why);
        if (!m) {
          throw Error(StrCat(
              tree.path.string(), ": ", key, " (", what, "): ",
              !node->IsMap() && !node->IsSeq()
                  ? std::string("not a matrix (expected !!opencv-matrix or a list of numbers)")
                  : why));
        }
        found = Found{tree.path, key, std::move(m->data)};
      }
    }
    return found;
  }

  // An integer pair (width, height) under one of the spellings, or {0, 0}.
  std::pair<int, int> Size(const std::vector<std::pair<std::string, std::string>>& pairs,
                           const std::vector<std::string>& vectors, std::string* source) const {
    const auto side = [](std::optional<double> v) {
      return v && *v >= 1 && *v <= util::kMaxImageSidePx && *v == std::floor(*v);
    };
    for (const TextTree& tree : trees_) {
      for (const auto& [wk, hk] : pairs) {
        const TextNode *w = tree.root.Find(wk), *h = tree.root.Find(hk);
        if (w && h && w->Integer() && h->Integer()) {
          *source = StrCat(tree.path.filename().string(), ": ", wk, " ", hk);
          return {static_cast<int>(*w->Integer()), static_cast<int>(*h->Integer())};
        }
      }
      for (const std::string& k : vectors) {
        const TextNode* n = tree.root.Find(k);
        if (n == nullptr || !(n->IsSeq() || n->IsMap())) continue;
        // [w, h], or a 2-element !!opencv-matrix (SLMaster's "S: [1280., 1024.]").
        const std::optional<TextMatrix> m = ToMatrix(*n);
        if (!m || m->data.size() != 2) continue;
        if (side(m->data[0]) && side(m->data[1])) {
          *source = StrCat(tree.path.filename().string(), ": ", k);
          return {static_cast<int>(m->data[0]), static_cast<int>(m->data[1])};
        }
      }
    }
    return {0, 0};
  }

 private:
  std::vector<TextTree> trees_;
};

std::string Where(const Found& f) { return StrCat(f.file.string(), ": ", f.key); }

CameraModel Camera(const Found& k, const std::optional<Found>& d, int width, int height,
                   const char* device) {
  return CameraFromMatrices(k.m, d ? &d->m : nullptr, width, height, device, Where(k),
                            d ? Where(*d) : std::string());
}

Rigid3d Extrinsics(const Found& r, const Found& t, const char* what) {
  return RigidFromMatrices(r.m, t.m, 1.0, what, Where(r), Where(t));
}

}  // namespace

const std::vector<std::string>& OpenCvCameraMatrixSpellings() { return kLeftK; }

OpenCvCalibration ReadOpenCvKeySpellings(const std::vector<fs::path>& paths, int camera_width,
                                         int camera_height, int projector_width,
                                         int projector_height) {
  if (paths.empty()) throw Error("no OpenCV calibration file given");
  const Files files(paths);
  OpenCvCalibration out;
  out.format = "opencv";
  auto note = [&](const std::optional<Found>& f, const char* what) {
    if (f) out.keys_used.push_back(StrCat(Where(*f), " -> ", what));
  };
  const auto lk = files.Matrix(kLeftK, "left camera matrix");
  const auto ld = files.Matrix(kLeftD, "left distortion");
  const auto rk = files.Matrix(kRightK, "right camera matrix");
  const auto rd = files.Matrix(kRightD, "right distortion");
  const auto pk = files.Matrix(kProjK, "projector matrix");
  const auto pd = files.Matrix(kProjD, "projector distortion");
  const auto rr = files.Matrix(kRightR, "right_from_left rotation");
  const auto rt = files.Matrix(kRightT, "right_from_left translation");
  const auto pr = files.Matrix(kProjR, "projector_from_left rotation");
  const auto pt = files.Matrix(kProjT, "projector_from_left translation");
  const std::string names = [&] {
    std::string s;
    for (const auto& p : paths) s += (s.empty() ? "" : ", ") + p.string();
    return s;
  }();
  if (!lk) {
    throw Error(StrCat(names, ": no camera matrix found (looked for ", kLeftK[0], ", ", kLeftK[1],
                       ", ", kLeftK[2], ", ... ; docs/formats.md lists the spellings)"));
  }
  std::string size_source;
  auto [w, h] = files.Size({{"image_width", "image_height"},
                            {"imageWidth", "imageHeight"},
                            {"width", "height"},
                            {"camera_width", "camera_height"}},
                           {"imageSize", "image_size", "img_size", "imgSize", "S"}, &size_source);
  if (w > 0 && h > 0) {
    out.keys_used.push_back(StrCat(size_source, " -> camera image size ", w, "x", h));
  } else {
    w = camera_width;
    h = camera_height;
    if (w < 0 && lk->m.size() == 9) {
      // Description only (fringe info): twice the principal point stands in for the size.
      w = std::max(1, static_cast<int>(std::lround(2 * lk->m[2])));
      h = std::max(1, static_cast<int>(std::lround(2 * lk->m[5])));
      out.keys_used.push_back(StrCat("image size not in the file; assumed ", w, "x", h,
                                     " (twice the principal point) for this description"));
    } else if (w <= 0 || h <= 0) {
      throw Error(StrCat(names,
                         ": the camera image size is not in the file (image_width/"
                         "image_height or imageSize) and was not given"));
    }
    if (camera_width > 0) {
      out.keys_used.push_back(StrCat("camera image size ", w, "x", h, " given (not in the file)"));
    }
  }
  util::CheckRange(w, 1, util::kMaxImageSidePx, names, "camera image width");
  util::CheckRange(h, 1, util::kMaxImageSidePx, names, "camera image height");
  note(lk, "left camera matrix");
  note(ld, "left distortion");
  out.left = Camera(*lk, ld, w, h, "left");
  if (rk) {
    note(rk, "right camera matrix");
    note(rd, "right distortion");
    out.right = Camera(*rk, rd, w, h, "right");
  } else if (rd) {
    throw Error(StrCat(Where(*rd), ": right distortion without a right camera matrix"));
  }
  if (pk) {
    std::string psource;
    auto [pw, ph] = files.Size({{"projector_width", "projector_height"},
                                {"projectorWidth", "projectorHeight"},
                                {"proj_width", "proj_height"}},
                               {"projectorSize", "projector_size", "projSize"}, &psource);
    if (!(pw > 0 && ph > 0) && projector_width > 0 && projector_height > 0) {
      pw = projector_width;
      ph = projector_height;
      psource = "given (not in the file)";
    }
    if (pw > 0 && ph > 0) {
      util::CheckRange(pw, 1, util::kMaxImageSidePx, names, "projector width");
      util::CheckRange(ph, 1, util::kMaxImageSidePx, names, "projector height");
      note(pk, "projector matrix");
      note(pd, "projector distortion");
      out.keys_used.push_back(StrCat(psource, " -> projector size ", pw, "x", ph));
      out.projector = Camera(*pk, pd, pw, ph, "projector");
    } else {
      out.keys_used.push_back(StrCat(Where(*pk),
                                     ": projector ignored (its size is not in the file: "
                                     "projector_width/projector_height or projectorSize)"));
    }
  }
  // R/T describe the second device: the right camera, or the projector when the file has one
  // camera and a projector (camera-projector systems).
  if (rr || rt) {
    if (!rr || !rt) {
      throw Error(StrCat(Where(rr ? *rr : *rt), ": rotation and translation come in pairs"));
    }
    if (out.right || !pk) {
      out.right_from_left = Extrinsics(*rr, *rt, "right_from_left");
      note(rr, "right_from_left rotation");
      note(rt, "right_from_left translation (mm)");
    } else if (out.projector && !pr) {
      out.projector_from_left = Extrinsics(*rr, *rt, "projector_from_left");
      note(rr, "projector_from_left rotation");
      note(rt, "projector_from_left translation (mm)");
    }
  }
  if (pr || pt) {
    if (!pr || !pt) {
      throw Error(StrCat(Where(pr ? *pr : *pt), ": rotation and translation come in pairs"));
    }
    if (out.projector) {
      out.projector_from_left = Extrinsics(*pr, *pt, "projector_from_left");
      note(pr, "projector_from_left rotation");
      note(pt, "projector_from_left translation (mm)");
    }
  }
  if (out.projector && !out.projector_from_left) {
    out.keys_used.push_back("projector ignored: no projector extrinsics (Rlp/Tlp or similar)");
    out.projector.reset();
  }
  return out;
}

CameraModel CameraFromMatrices(const std::vector<double>& k, const std::vector<double>* d,
                               int width, int height, const std::string& device,
                               const std::string& k_where, const std::string& d_where) {
  if (k.size() != 9) {
    throw Error(StrCat(k_where, " (", device, " camera matrix): ", k.size(),
                       " entries, expected a 3x3 matrix"));
  }
  const double* a = k.data();
  if (a[1] != 0 || a[3] != 0 || a[6] != 0 || a[7] != 0 || a[8] != 1) {
    // Skew or a scaled matrix: fringe's model has neither.
    throw Error(StrCat(k_where, " (", device,
                       " camera matrix): expected [fx 0 cx; 0 fy cy; 0 0 1] (no skew)"));
  }
  CameraModel c;
  c.width = width;
  c.height = height;
  c.fx = a[0];
  c.cx = a[2];
  c.fy = a[4];
  c.cy = a[5];
  std::array<double, 5> dist{0, 0, 0, 0, 0};
  if (d) {
    const int n = static_cast<int>(d->size());
    if (n != 4 && n != 5 && n != 8 && n != 12 && n != 14) {
      throw Error(StrCat(d_where, " (", device, " distortion): ", n,
                         " coefficients; expected 4 or 5 (k1 k2 p1 p2 [k3])"));
    }
    for (int i = 5; i < n; ++i) {
      if ((*d)[i] != 0) {
        throw Error(StrCat(d_where, " (", device, " distortion): ", n,
                           " coefficients (OpenCV's rational / thin-prism / tilt model); fringe's "
                           "model is k1 k2 p1 p2 k3 and coefficient ",
                           i, " is ", (*d)[i],
                           ", not 0: recalibrate with the 5-coefficient model"));
      }
    }
    for (int i = 0; i < std::min(n, 5); ++i) dist[i] = (*d)[i];
  }
  c.SetDistortion(dist);
  try {
    c.Check();
  } catch (const Error& e) {
    throw Error(StrCat(k_where, " (", device, " camera): ", e.what()));
  }
  CheckPlausibleCamera(c, StrCat(k_where, " (", device, " camera)"));
  return c;
}

Rigid3d RigidFromMatrices(const std::vector<double>& r, const std::vector<double>& t,
                          double mm_per_unit, const std::string& what, const std::string& r_where,
                          const std::string& t_where) {
  Eigen::Matrix3d m;
  if (r.size() == 9) {
    for (int i = 0; i < 9; ++i) m(i / 3, i % 3) = r[i];
  } else if (r.size() == 3) {
    // A Rodrigues vector (as cv::stereoCalibrate's callers sometimes save om).
    const Eigen::Vector3d om(r[0], r[1], r[2]);
    const double angle = om.norm();
    m = angle > 0 ? Eigen::AngleAxisd(angle, om / angle).toRotationMatrix()
                  : Eigen::Matrix3d::Identity();
  } else {
    throw Error(StrCat(r_where, " (", what, " rotation): ", r.size(),
                       " entries, expected a 3x3 matrix or a 3-vector"));
  }
  CheckRotationMatrix(m, StrCat(r_where, " (", what, " rotation)"));
  if (t.size() != 3) {
    throw Error(StrCat(t_where, " (", what, " translation): ", t.size(), " entries, expected 3"));
  }
  return Rigid3d(m, mm_per_unit * Eigen::Vector3d(t[0], t[1], t[2]));
}

namespace {

// The devices read, for the error messages of ToRig / ToCameraProjectorRig.
std::string Holdings(const OpenCvCalibration& c) {
  std::string have = c.left ? "left camera" : "";
  if (c.right) have += ", right camera";
  if (c.projector) have += ", projector";
  return have.empty() ? "nothing usable" : have;
}

}  // namespace

StereoRig OpenCvCalibration::ToRig(const std::string& context) const {
  if (!left || !right || !right_from_left) {
    throw Error(StrCat(context,
                       ": fringe reconstructs with two cameras and their extrinsics "
                       "(R/T); the file holds: ",
                       Holdings(*this)));
  }
  StereoRig rig;
  rig.left = *left;
  rig.right = *right;
  rig.right_from_left = *right_from_left;
  if (projector && projector_from_left) {
    rig.projector = *projector;
    rig.projector_from_left = *projector_from_left;
  }
  return rig;
}

StereoRig OpenCvCalibration::ToCameraProjectorRig(const std::string& context) const {
  if (!left || !projector || !projector_from_left) {
    throw Error(StrCat(context,
                       ": camera-projector mode needs a camera, the projector (with its size) and "
                       "their extrinsics (Rlp/Tlp or similar); the file holds: ",
                       Holdings(*this)));
  }
  StereoRig rig;
  rig.left = *left;
  rig.right = right ? *right : *left;
  if (right && right_from_left) rig.right_from_left = *right_from_left;
  rig.projector = *projector;
  rig.projector_from_left = *projector_from_left;
  return rig;
}

std::string OpenCvCalibration::Describe() const {
  std::ostringstream os;
  if (!format.empty()) os << "  format: " << format << "\n";
  os << "  devices:";
  if (left) os << " left camera";
  if (right) os << ", right camera";
  if (projector) os << ", projector";
  os << "\n";
  for (const auto& k : keys_used) os << "  " << k << "\n";
  if (right_from_left) {
    os << "  baseline " << right_from_left->translation().norm() << " (file units, taken as mm)\n";
  }
  return os.str();
}

}  // namespace fringe::io
