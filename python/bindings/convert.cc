#include "convert.h"

#include <cmath>

#include "fringe/util/error.h"

namespace fringe::python {

namespace {

py::dtype DtypeOfDepth(int depth) {
  switch (depth) {
    case CV_8U:
      return py::dtype::of<uint8_t>();
    case CV_8S:
      return py::dtype::of<int8_t>();
    case CV_16U:
      return py::dtype::of<uint16_t>();
    case CV_16S:
      return py::dtype::of<int16_t>();
    case CV_32S:
      return py::dtype::of<int32_t>();
    case CV_32F:
      return py::dtype::of<float>();
    case CV_64F:
      return py::dtype::of<double>();
    default:
      throw Error(util::StrCat("cannot convert an image of OpenCV depth ", depth, " to numpy"));
  }
}

std::string ShapeText(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) {
    s += (i ? ", " : "") + std::to_string(a.shape(i));
  }
  return s + (a.ndim() == 1 ? ",)" : ")");
}

cv::Mat WrapImage(py::array& a, const std::string& what) {
  if (a.ndim() != 2) {
    throw py::value_error(what + ": expected a 2-D image array, got shape " + ShapeText(a));
  }
  int type = -1;
  if (a.dtype().is(py::dtype::of<uint8_t>())) {
    type = CV_8UC1;
  } else if (a.dtype().is(py::dtype::of<uint16_t>())) {
    type = CV_16UC1;
  } else {
    throw py::type_error(what + ": expected a uint8 or uint16 image, got " +
                         std::string(py::str(a.dtype())));
  }
  if (!(a.flags() & py::array::c_style)) {
    // Copy into C order once; the Mat then wraps the copy, which `a` now owns.
    a = py::array::ensure(a, py::array::c_style);
  }
  return cv::Mat(static_cast<int>(a.shape(0)), static_cast<int>(a.shape(1)), type,
                 const_cast<void*>(a.data()), static_cast<size_t>(a.strides(0)));
}

}  // namespace

py::object ArrayFromMat(const cv::Mat& mat) {
  if (mat.empty()) return py::none();
  // A Mat over external memory (no reference count) is copied so the array owns its data.
  auto* keep = new cv::Mat(mat.u ? mat : mat.clone());
  py::capsule owner(keep, [](void* p) { delete static_cast<cv::Mat*>(p); });
  const py::ssize_t elem = static_cast<py::ssize_t>(keep->elemSize1());
  std::vector<py::ssize_t> shape = {keep->rows, keep->cols};
  std::vector<py::ssize_t> strides = {static_cast<py::ssize_t>(keep->step[0]),
                                      static_cast<py::ssize_t>(keep->elemSize())};
  if (keep->channels() > 1) {
    shape.push_back(keep->channels());
    strides.push_back(elem);
  }
  return py::array(DtypeOfDepth(keep->depth()), shape, strides, keep->data, owner);
}

py::list ArraysFromMats(const std::vector<cv::Mat>& images) {
  py::list out;
  for (const auto& image : images) out.append(ArrayFromMat(image));
  return out;
}

ImageStack ImagesFromPython(const py::handle& images, const std::string& what) {
  ImageStack stack;
  if (py::isinstance<py::array>(images) && py::reinterpret_borrow<py::array>(images).ndim() == 3) {
    // One (N, H, W) array: each image is a view of one plane (no copy).
    auto a = py::reinterpret_borrow<py::array>(images);
    for (py::ssize_t i = 0; i < a.shape(0); ++i) {
      stack.arrays.push_back(py::array::ensure(py::object(a[py::int_(i)])));
    }
  } else if (py::isinstance<py::sequence>(images) && !py::isinstance<py::str>(images)) {
    for (py::handle item : py::reinterpret_borrow<py::sequence>(images)) {
      if (!py::isinstance<py::array>(item)) {
        throw py::type_error(what + "[" + std::to_string(stack.arrays.size()) +
                             "]: expected a numpy array, got " +
                             std::string(py::str(item.get_type().attr("__name__"))));
      }
      stack.arrays.push_back(py::reinterpret_borrow<py::array>(item));
    }
  } else {
    throw py::type_error(what + ": expected a list of 2-D numpy arrays or one (N, H, W) array");
  }
  for (size_t i = 0; i < stack.arrays.size(); ++i) {
    stack.mats.push_back(WrapImage(stack.arrays[i], what + "[" + std::to_string(i) + "]"));
  }
  return stack;
}

std::vector<Eigen::Vector3d> PointsFromPython(const py::handle& points, const std::string& what,
                                              bool drop_non_finite) {
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(points);
  if (!a) {
    PyErr_Clear();
    throw py::type_error(what + ": expected an array of points (N, 3)");
  }
  if (a.ndim() < 1 || a.shape(a.ndim() - 1) != 3) {
    throw py::value_error(what + ": expected points of shape (N, 3) or (H, W, 3), got " +
                          ShapeText(a));
  }
  const size_t n = static_cast<size_t>(a.size() / 3);
  const double* data = a.data();
  std::vector<Eigen::Vector3d> out;
  out.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p(data[3 * i], data[3 * i + 1], data[3 * i + 2]);
    if (drop_non_finite && !p.allFinite()) continue;
    out.push_back(p);
  }
  return out;
}

py::array ViewVec3(std::vector<Eigen::Vector3d>& v, const std::vector<py::ssize_t>& shape,
                   const py::handle& owner) {
  static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double), "Vector3d must be packed");
  std::vector<py::ssize_t> full = shape;
  full.push_back(3);
  std::vector<py::ssize_t> strides(full.size());
  py::ssize_t stride = sizeof(double);
  for (size_t i = full.size(); i-- > 0;) {
    strides[i] = stride;
    stride *= full[i];
  }
  return py::array(py::dtype::of<double>(), full, strides, v.empty() ? nullptr : v.front().data(),
                   owner);
}

py::array MatrixFromRigid(const Rigid3d& t) {
  const Eigen::Matrix4d m = t.ToMatrix4();
  py::array_t<double> out({4, 4});
  auto r = out.mutable_unchecked<2>();
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) r(i, j) = m(i, j);
  }
  return out;
}

Rigid3d RigidFromPython(const py::handle& m, const std::string& what) {
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(m);
  if (!a || a.ndim() != 2 || (a.shape(0) != 3 && a.shape(0) != 4) || a.shape(1) != 4) {
    PyErr_Clear();
    throw py::value_error(what + ": expected a 4x4 (or 3x4) rigid transform matrix");
  }
  Eigen::Matrix<double, 3, 4> rt;
  auto r = a.unchecked<2>();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) rt(i, j) = r(i, j);
  }
  if (!rt.allFinite()) throw py::value_error(what + ": the matrix has a NaN or infinite entry");
  return Rigid3d::FromMatrix(rt);
}

py::object FromJson(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null:
      return py::none();
    case nlohmann::json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
      return py::int_(j.get<int64_t>());
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(j.get<uint64_t>());
    case nlohmann::json::value_t::number_float:
      return py::float_(j.get<double>());
    case nlohmann::json::value_t::string:
      return py::str(j.get<std::string>());
    case nlohmann::json::value_t::array: {
      py::list list;
      for (const auto& item : j) list.append(FromJson(item));
      return std::move(list);
    }
    case nlohmann::json::value_t::object: {
      py::dict dict;
      for (const auto& item : j.items()) dict[py::str(item.key())] = FromJson(item.value());
      return std::move(dict);
    }
    default:
      return py::none();
  }
}

void ApplyOptions(py::object options, const py::dict& values, const std::string& path) {
  const py::object type = py::type::of(options);
  const py::object property = py::module_::import("builtins").attr("property");
  for (auto item : values) {
    const std::string key = py::str(item.first);
    const py::object descriptor = py::getattr(type, key.c_str(), py::none());
    if (descriptor.is_none() || !py::isinstance(descriptor, property)) {
      throw py::type_error(path + " has no option '" + key + "'");
    }
    py::object current = options.attr(key.c_str());
    if (py::isinstance<py::dict>(item.second) && !py::isinstance<py::dict>(current)) {
      // Nested options given as a dict: current is a reference into `options`.
      ApplyOptions(current, py::reinterpret_borrow<py::dict>(item.second), path + "." + key);
      continue;
    }
    try {
      options.attr(key.c_str()) = item.second;
    } catch (py::error_already_set& e) {
      if (!e.matches(PyExc_TypeError)) throw;
      throw py::type_error(path + "." + key + ": expected " +
                           std::string(py::str(py::type::of(current).attr("__name__"))) + ", got " +
                           std::string(py::str(item.second.get_type().attr("__name__"))));
    }
  }
}

}  // namespace fringe::python
