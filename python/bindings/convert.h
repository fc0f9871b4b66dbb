// Conversions between numpy arrays and fringe's types, shared by the binding files.
//
// Ownership: arrays returned to Python view C++ memory without copying whenever the layout
// allows (cv::Mat buffers are shared through their reference count; struct-of-arrays clouds are
// viewed through the Python object that owns them). Inputs are wrapped without copying when
// they are C-contiguous arrays of the expected type and copied otherwise.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"

namespace fringe::python {

namespace py = pybind11;

// A cv::Mat as a numpy array sharing its buffer (the array keeps the buffer alive). CV_8U ->
// uint8, CV_16U -> uint16, CV_32F -> float32, CV_64F -> float64, CV_32S -> int32; channels
// become a last axis. An empty Mat gives None.
py::object ArrayFromMat(const cv::Mat& mat);

// Images for the C++ side: `mats` wrap the numpy buffers, which `arrays` keep alive. Accepts a
// sequence of 2-D uint8/uint16 arrays or one (N, H, W) array. `what` names the argument in
// errors ("left[3]: ...").
struct ImageStack {
  std::vector<py::array> arrays;
  std::vector<cv::Mat> mats;
};
ImageStack ImagesFromPython(const py::handle& images, const std::string& what);

// (..., 3) float array -> points (copied, as float64). With drop_non_finite, rows with a NaN
// or infinite coordinate are left out (organized (H, W, 3) clouds mark empty slots with NaN).
std::vector<Eigen::Vector3d> PointsFromPython(const py::handle& points, const std::string& what,
                                              bool drop_non_finite);

// A vector of Eigen 3-vectors (contiguous doubles) viewed as an (rows, cols, 3) or (n, 3)
// float64 array whose lifetime is tied to `owner`.
py::array ViewVec3(std::vector<Eigen::Vector3d>& v, const std::vector<py::ssize_t>& shape,
                   const py::handle& owner);
template <typename T>
py::array ViewVector(std::vector<T>& v, const std::vector<py::ssize_t>& shape,
                     const py::handle& owner) {
  std::vector<py::ssize_t> strides(shape.size());
  py::ssize_t stride = sizeof(T);
  for (size_t i = shape.size(); i-- > 0;) {
    strides[i] = stride;
    stride *= shape[i];
  }
  return py::array(py::dtype::of<T>(), shape, strides, v.data(), owner);
}

// 4x4 homogeneous matrix <-> Rigid3d (3x4 also accepted on input).
py::array MatrixFromRigid(const Rigid3d& t);
Rigid3d RigidFromPython(const py::handle& m, const std::string& what);

// nlohmann::json -> Python dict/list/... (the JSON the CLI prints).
py::object FromJson(const nlohmann::json& j);

// Sets the fields of a bound options object from keyword arguments; nested options take a dict
// or an options object. Unknown names raise TypeError naming the options type and the field.
void ApplyOptions(py::object options, const py::dict& values, const std::string& path);

// The options object `base` (or default-constructed Options when None) with `kwargs` applied,
// Check()ed (fringe::Error, raised as fringe.Error, names the field).
template <typename Options>
Options MakeOptions(const py::object& base, const py::kwargs& kwargs, const char* name) {
  py::object options = base.is_none() ? py::cast(Options{}) : py::cast(base.cast<Options>());
  ApplyOptions(options, kwargs, name);
  Options result = options.cast<Options>();
  result.Check();
  return result;
}

// The constructor of a bound options type: Options(**fields), C++ defaults for the rest.
template <typename Options>
auto OptionsInit(const char* name) {
  return py::init(
      [name](const py::kwargs& kw) { return MakeOptions<Options>(py::none(), kw, name); });
}

// Images as a list of numpy arrays sharing their buffers.
py::list ArraysFromMats(const std::vector<cv::Mat>& images);

}  // namespace fringe::python
