// Cameras, rigs, point clouds and PLY files.
#include <pybind11/operators.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.h"
#include "convert.h"
#include "fringe/geometry/camera.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/geometry/triangle_mesh.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/mesh_io.h"
#include "fringe/io/opencv_calibration.h"
#include "fringe/io/ply.h"
#include "fringe/util/error.h"

namespace fringe::python {

namespace {

// (N, 2) float64 array from a function of one row of an (N, k) input.
template <int kIn, typename F>
py::array_t<double> MapRows(const py::handle& input, const char* what, int out_cols, F&& f) {
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(input);
  if (!a || a.ndim() < 1 || a.shape(a.ndim() - 1) != kIn) {
    PyErr_Clear();
    throw py::value_error(util::StrCat(what, ": expected an array of shape (N, ", kIn, ")"));
  }
  const py::ssize_t n = a.size() / kIn;
  std::vector<py::ssize_t> shape(a.shape(), a.shape() + a.ndim());
  shape.back() = out_cols;
  py::array_t<double> out(shape);
  const double* in = a.data();
  double* o = out.mutable_data();
  {
    py::gil_scoped_release release;
    for (py::ssize_t i = 0; i < n; ++i) f(in + kIn * i, o + out_cols * i);
  }
  return out;
}

io::PlyFormat PlyFormatOf(bool ascii) {
  return ascii ? io::PlyFormat::kAscii : io::PlyFormat::kBinaryLittleEndian;
}

template <typename T>
void SetAttribute(std::vector<T>& dst, const py::handle& src, size_t n, const char* what) {
  if (src.is_none()) {
    dst.clear();
    return;
  }
  auto a = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(src);
  if (!a || static_cast<size_t>(a.size()) != n) {
    PyErr_Clear();
    throw py::value_error(util::StrCat(what, ": expected ", n, " values (one per point)"));
  }
  dst.assign(a.data(), a.data() + n);
}

std::vector<TriangleMesh::Triangle> TrianglesFromPython(const py::handle& triangles) {
  std::vector<TriangleMesh::Triangle> out;
  if (triangles.is_none()) return out;
  auto a = py::array_t<int32_t, py::array::c_style | py::array::forcecast>::ensure(triangles);
  if (!a || a.ndim() != 2 || a.shape(1) != 3) {
    PyErr_Clear();
    throw py::value_error("triangles: expected an integer array of shape (M, 3)");
  }
  out.resize(static_cast<size_t>(a.shape(0)));
  if (!out.empty()) std::copy(a.data(), a.data() + a.size(), out.front().data());
  return out;
}

// A mesh with the cloud's points, normals and colours as vertices (the attributes the mesh
// writer keeps) and the given triangles, checked.
TriangleMesh MeshOfCloud(const PointCloud& cloud, std::vector<TriangleMesh::Triangle> triangles,
                         const std::string& context) {
  TriangleMesh mesh;
  mesh.vertices = cloud.points;
  mesh.normals = cloud.normals;
  mesh.colors = cloud.colors;
  mesh.triangles = std::move(triangles);
  mesh.Check(context);
  return mesh;
}

// Writes a cloud, or with triangles a mesh (vertex intensity and quality are not kept then).
void WriteCloudOrMesh(const std::filesystem::path& path, const PointCloud& cloud,
                      const py::object& triangles, bool ascii,
                      const std::vector<std::string>& comments) {
  cloud.CheckConsistent();
  if (triangles.is_none()) {
    py::gil_scoped_release release;
    io::WritePly(path, cloud, PlyFormatOf(ascii), comments);
    return;
  }
  if (cloud.has_intensity() || cloud.has_quality() || cloud.has_residual()) {
    // The mesh writer keeps normals and colours only; dropping data silently would surprise.
    throw py::value_error(
        "write_ply: with triangles the file is a mesh (vertices, normals, colours): leave out "
        "intensity, quality and residual_px");
  }
  const TriangleMesh mesh = MeshOfCloud(cloud, TrianglesFromPython(triangles), path.string());
  py::gil_scoped_release release;
  io::WritePly(path, mesh, PlyFormatOf(ascii), comments);
}

}  // namespace

// A PointCloud built from numpy arrays (copied into the C++ struct-of-arrays layout).
PointCloud CloudFromArrays(const py::handle& points, const py::handle& normals,
                           const py::handle& colors, const py::handle& intensity,
                           const py::handle& quality) {
  PointCloud c;
  c.points = PointsFromPython(points, "points", false);
  const size_t n = c.points.size();
  if (!normals.is_none()) {
    c.normals = PointsFromPython(normals, "normals", false);
    if (c.normals.size() != n) throw py::value_error("normals: expected one normal per point");
  }
  if (!colors.is_none()) {
    std::vector<uint8_t> rgb;
    SetAttribute(rgb, colors, 3 * n, "colors");
    c.colors.resize(n);
    std::copy(rgb.begin(), rgb.end(), c.colors.front().data());
  }
  SetAttribute(c.intensity, intensity, n, "intensity");
  SetAttribute(c.quality, quality, n, "quality");
  return c;
}

TriangleMesh MeshFromPython(const py::handle& mesh, const std::string& what) {
  if (py::isinstance<TriangleMesh>(mesh)) return mesh.cast<TriangleMesh>();
  if (py::isinstance<io::PlyData>(mesh)) {
    const auto& ply = mesh.cast<const io::PlyData&>();
    TriangleMesh out = MeshOfCloud(ply.cloud, ply.triangles, what);
    return out;
  }
  if (py::isinstance<py::str>(mesh) ||
      py::isinstance(mesh, py::module_::import("os").attr("PathLike"))) {
    const auto path = mesh.cast<std::filesystem::path>();
    py::gil_scoped_release release;
    return io::ReadMesh(path);
  }
  if (py::isinstance<py::tuple>(mesh) && py::len(mesh) == 2) {
    auto t = mesh.cast<py::tuple>();
    TriangleMesh out;
    out.vertices = PointsFromPython(t[0], what + " vertices", false);
    out.triangles = TrianglesFromPython(t[1]);
    out.Check(what);
    return out;
  }
  throw py::type_error(what +
                       ": expected a fringe.Mesh, a PlyFile (fringe.read_ply), a mesh file path "
                       "or (vertices (V, 3), triangles (M, 3))");
}

void BindGeometryIo(py::module_& m) {
  py::class_<CameraModel>(m, "Camera", R"doc(
Pinhole camera with OpenCV lens distortion (k1 k2 p1 p2 k3); also the projector model.
Frames: x right, y down, z forward, millimetres; pixel (0, 0) is the centre of the top-left pixel.)doc")
      .def(py::init([](py::kwargs kwargs) {
             return MakeOptions<CameraModel>(py::none(), kwargs, "Camera");
           }),
           "Camera(**fields): the C++ defaults (1280x1024, f = 2500 px) with the given fields.")
      .def_readwrite("width", &CameraModel::width)
      .def_readwrite("height", &CameraModel::height)
      .def_readwrite("fx", &CameraModel::fx)
      .def_readwrite("fy", &CameraModel::fy)
      .def_readwrite("cx", &CameraModel::cx)
      .def_readwrite("cy", &CameraModel::cy)
      .def_readwrite("k1", &CameraModel::k1)
      .def_readwrite("k2", &CameraModel::k2)
      .def_readwrite("p1", &CameraModel::p1)
      .def_readwrite("p2", &CameraModel::p2)
      .def_readwrite("k3", &CameraModel::k3)
      .def_property_readonly(
          "K",
          [](const CameraModel& c) {
            const Eigen::Matrix3d k = c.K();
            py::array_t<double> out({3, 3});
            for (int i = 0; i < 3; ++i)
              for (int j = 0; j < 3; ++j) out.mutable_at(i, j) = k(i, j);
            return out;
          },
          "3x3 intrinsic matrix.")
      .def_static("reference_camera", &CameraModel::ReferenceCamera,
                  "The reference rig camera (1280x1024, 4.8 um pixels, 12 mm lens).")
      .def_static("reference_projector", &CameraModel::ReferenceProjector,
                  "The reference projector (1280x800).")
      .def("check", &CameraModel::Check, "Raises fringe.Error naming a field out of range.")
      .def(
          "project",
          [](const CameraModel& c, const py::handle& p) {
            return MapRows<3>(p, "project: points", 2, [&c](const double* in, double* out) {
              const Eigen::Vector2d px = c.Project(Eigen::Vector3d(in[0], in[1], in[2]));
              out[0] = px.x();
              out[1] = px.y();
            });
          },
          py::arg("points_in_camera"),
          "Pixels (N, 2) of points (N, 3) in the camera frame (Z > 0).")
      .def(
          "unproject",
          [](const CameraModel& c, const py::handle& p) {
            return MapRows<2>(p, "unproject: pixels", 2, [&c](const double* in, double* out) {
              const Eigen::Vector2d xy = c.Unproject(Eigen::Vector2d(in[0], in[1]));
              out[0] = xy.x();
              out[1] = xy.y();
            });
          },
          py::arg("pixels"), "Undistorted normalized coordinates (N, 2) of pixels (N, 2).")
      .def(
          "ray",
          [](const CameraModel& c, const py::handle& p) {
            return MapRows<2>(p, "ray: pixels", 3, [&c](const double* in, double* out) {
              const Eigen::Vector3d r = c.Ray(Eigen::Vector2d(in[0], in[1]));
              out[0] = r.x();
              out[1] = r.y();
              out[2] = r.z();
            });
          },
          py::arg("pixels"),
          "Unit ray directions (N, 3) in the camera frame through pixels (N, 2).")
      .def(py::self == py::self)
      .def("__repr__", [](const CameraModel& c) {
        return util::StrCat("fringe.Camera(", c.width, "x", c.height, ", fx=", c.fx, ", fy=", c.fy,
                            ", cx=", c.cx, ", cy=", c.cy, ")");
      });

  py::class_<StereoRig>(m, "Rig", R"doc(
The sensor head: left and right cameras and optionally a calibrated projector. The sensor frame
is the left camera frame; transforms are 4x4 matrices b_from_a, millimetres.)doc")
      .def(py::init<>())
      .def_readwrite("left", &StereoRig::left)
      .def_readwrite("right", &StereoRig::right)
      .def_readwrite("projector", &StereoRig::projector, "Camera or None.")
      .def_property(
          "right_from_left", [](const StereoRig& r) { return MatrixFromRigid(r.right_from_left); },
          [](StereoRig& r, const py::handle& t) {
            r.right_from_left = RigidFromPython(t, "right_from_left");
          },
          "4x4 transform from the left to the right camera frame.")
      .def_property(
          "projector_from_left",
          [](const StereoRig& r) { return MatrixFromRigid(r.projector_from_left); },
          [](StereoRig& r, const py::handle& t) {
            r.projector_from_left = RigidFromPython(t, "projector_from_left");
          },
          "4x4 transform from the left camera to the projector frame.")
      .def_property_readonly("baseline_mm", &StereoRig::BaselineMm)
      .def_static(
          "reference", &StereoRig::Reference,
          "The reference rig of SPEC.md (200 mm baseline, converging at 500 mm, projector).")
      .def_static(
          "load", [](const std::filesystem::path& p) { return io::ReadRig(p); }, py::arg("path"),
          "Reads a rig JSON file (or a single-camera calibration file).")
      .def(
          "save", [](const StereoRig& r, const std::filesystem::path& p) { io::WriteRig(p, r); },
          py::arg("path"), "Writes the rig JSON file atomically.")
      .def_static(
          "from_opencv",
          [](const py::object& files, int width, int height) {
            std::vector<std::filesystem::path> paths;
            if (py::isinstance<py::str>(files) ||
                py::isinstance(files, py::module_::import("os").attr("PathLike"))) {
              paths.push_back(files.cast<std::filesystem::path>());
            } else {
              paths = files.cast<std::vector<std::filesystem::path>>();
            }
            if (paths.empty()) throw py::value_error("from_opencv: no files");
            py::gil_scoped_release release;
            return io::ReadOpenCvCalibration(paths, width, height).ToRig(paths[0].string());
          },
          py::arg("files"), py::arg("width") = 0, py::arg("height") = 0,
          "The rig of OpenCV calibration files (YAML/XML; one path or a list, e.g. stereo_calib's\n"
          "intrinsics and extrinsics), as `fringe convert-calib`; width/height when the files do\n"
          "not store the image size.")
      .def(
          "to_dict", [](const StereoRig& r) { return FromJson(io::RigToJson(r)); },
          "The rig JSON of docs/formats.md as a dict.")
      .def("check", &StereoRig::Check)
      .def("__repr__", [](const StereoRig& r) {
        return util::StrCat("fringe.Rig(", r.left.width, "x", r.left.height, ", baseline ",
                            r.BaselineMm(), " mm", r.projector ? ", projector" : "", ")");
      });

  py::class_<PointCloud, std::shared_ptr<PointCloud>>(m, "PointCloud", R"doc(
An unorganized point cloud. Attributes are numpy views of the C++ storage (no copy), or None
when absent: points (N, 3) float64 mm, normals (N, 3), colors (N, 3) uint8, intensity (N,)
float32, quality (N,) float32. Assigning an attribute copies the array in.)doc")
      .def(py::init(&CloudFromArrays), py::arg("points"), py::arg("normals") = py::none(),
           py::arg("colors") = py::none(), py::arg("intensity") = py::none(),
           py::arg("quality") = py::none())
      .def("__len__", &PointCloud::size)
      .def_property(
          "points",
          [](py::object self) {
            auto& c = self.cast<PointCloud&>();
            return ViewVec3(c.points, {static_cast<py::ssize_t>(c.size())}, self);
          },
          [](PointCloud& c, const py::handle& a) {
            auto p = PointsFromPython(a, "points", false);
            if (p.size() != c.size() &&
                (c.has_normals() || c.has_colors() || c.has_intensity() || c.has_quality())) {
              throw py::value_error("points: the cloud has attributes for " +
                                    std::to_string(c.size()) + " points");
            }
            c.points = std::move(p);
          })
      .def_property(
          "normals",
          [](py::object self) -> py::object {
            auto& c = self.cast<PointCloud&>();
            if (!c.has_normals()) return py::none();
            return ViewVec3(c.normals, {static_cast<py::ssize_t>(c.size())}, self);
          },
          [](PointCloud& c, const py::handle& a) {
            if (a.is_none()) return c.normals.clear();
            auto n = PointsFromPython(a, "normals", false);
            if (n.size() != c.size())
              throw py::value_error("normals: expected one normal per point");
            c.normals = std::move(n);
          })
      .def_property(
          "colors",
          [](py::object self) -> py::object {
            auto& c = self.cast<PointCloud&>();
            if (!c.has_colors()) return py::none();
            return py::array(py::dtype::of<uint8_t>(),
                             {static_cast<py::ssize_t>(c.size()), py::ssize_t{3}},
                             {py::ssize_t{3}, py::ssize_t{1}}, c.colors.front().data(), self);
          },
          [](PointCloud& c, const py::handle& a) {
            std::vector<uint8_t> rgb;
            SetAttribute(rgb, a, 3 * c.size(), "colors");
            c.colors.resize(rgb.empty() ? 0 : c.size());
            if (!rgb.empty()) std::copy(rgb.begin(), rgb.end(), c.colors.front().data());
          })
      .def_property(
          "intensity",
          [](py::object self) -> py::object {
            auto& c = self.cast<PointCloud&>();
            if (!c.has_intensity()) return py::none();
            return ViewVector(c.intensity, {static_cast<py::ssize_t>(c.size())}, self);
          },
          [](PointCloud& c, const py::handle& a) {
            SetAttribute(c.intensity, a, c.size(), "intensity");
          })
      .def_property(
          "quality",
          [](py::object self) -> py::object {
            auto& c = self.cast<PointCloud&>();
            if (!c.has_quality()) return py::none();
            return ViewVector(c.quality, {static_cast<py::ssize_t>(c.size())}, self);
          },
          [](PointCloud& c, const py::handle& a) {
            SetAttribute(c.quality, a, c.size(), "quality");
          })
      .def_property(
          "residual_px",
          [](py::object self) -> py::object {
            auto& c = self.cast<PointCloud&>();
            if (!c.has_residual()) return py::none();
            return ViewVector(c.residual_px, {static_cast<py::ssize_t>(c.size())}, self);
          },
          [](PointCloud& c, const py::handle& a) {
            SetAttribute(c.residual_px, a, c.size(), "residual_px");
          })
      .def("__repr__", [](const PointCloud& c) {
        return util::StrCat("fringe.PointCloud(", c.size(), " points",
                            c.has_normals() ? ", normals" : "", c.has_colors() ? ", colors" : "",
                            c.has_intensity() ? ", intensity" : "",
                            c.has_quality() ? ", quality" : "", ")");
      });

  py::class_<TriangleMesh, std::shared_ptr<TriangleMesh>>(m, "Mesh", R"doc(
A triangle mesh. Arrays view the C++ storage (no copy): vertices (V, 3) float64 mm, triangles
(M, 3) int32 (counter-clockwise from outside), normals (V, 3) or None, colors (V, 3) uint8 or
None. Mesh(vertices, triangles, normals=None) copies the arrays in.)doc")
      .def(py::init([](const py::handle& vertices, const py::handle& triangles,
                       const py::handle& normals) {
             TriangleMesh mesh;
             mesh.vertices = PointsFromPython(vertices, "vertices", false);
             mesh.triangles = TrianglesFromPython(triangles);
             if (!normals.is_none()) mesh.normals = PointsFromPython(normals, "normals", false);
             mesh.Check("Mesh");
             return mesh;
           }),
           py::arg("vertices"), py::arg("triangles"), py::arg("normals") = py::none())
      .def_static(
          "load",
          [](const std::filesystem::path& p) {
            py::gil_scoped_release release;
            return io::ReadMesh(p);
          },
          py::arg("path"), "Reads a .ply, .stl or .obj mesh (io::ReadMesh).")
      .def(
          "save",
          [](const TriangleMesh& mesh, const std::filesystem::path& p,
             const std::vector<std::string>& comments) {
            py::gil_scoped_release release;
            io::WriteMesh(p, mesh, comments);
          },
          py::arg("path"), py::arg("comments") = std::vector<std::string>{},
          "Writes .ply, .stl or .obj by extension, atomically (io::WriteMesh).")
      .def_property_readonly(
          "vertices",
          [](py::object self) {
            auto& mesh = self.cast<TriangleMesh&>();
            return ViewVec3(mesh.vertices, {static_cast<py::ssize_t>(mesh.NumVertices())}, self);
          })
      .def_property_readonly("triangles",
                             [](py::object self) {
                               auto& mesh = self.cast<TriangleMesh&>();
                               const auto n = static_cast<py::ssize_t>(mesh.NumTriangles());
                               return py::array(py::dtype::of<int32_t>(), {n, py::ssize_t{3}},
                                                {py::ssize_t{12}, py::ssize_t{4}},
                                                n ? mesh.triangles.front().data() : nullptr, self);
                             })
      .def_property_readonly(
          "normals",
          [](py::object self) -> py::object {
            auto& mesh = self.cast<TriangleMesh&>();
            if (!mesh.has_normals()) return py::none();
            return ViewVec3(mesh.normals, {static_cast<py::ssize_t>(mesh.NumVertices())}, self);
          })
      .def_property_readonly("colors",
                             [](py::object self) -> py::object {
                               auto& mesh = self.cast<TriangleMesh&>();
                               if (!mesh.has_colors()) return py::none();
                               const auto n = static_cast<py::ssize_t>(mesh.NumVertices());
                               return py::array(py::dtype::of<uint8_t>(), {n, py::ssize_t{3}},
                                                {py::ssize_t{3}, py::ssize_t{1}},
                                                mesh.colors.front().data(), self);
                             })
      .def("__repr__", [](const TriangleMesh& mesh) {
        return util::StrCat("fringe.Mesh(", mesh.NumVertices(), " vertices, ", mesh.NumTriangles(),
                            " triangles)");
      });

  py::class_<io::PlyData, std::shared_ptr<io::PlyData>>(m, "PlyFile", R"doc(
A PLY file as read by fringe.read_ply: the vertices as a PointCloud, triangles (M, 3) int32
(empty when the file has no faces), grid_index (N,) uint32 and grid_shape (H, W) for organized
clouds written by fringe (None otherwise), and the header comments.)doc")
      .def_property_readonly("cloud",
                             [](py::object self) {
                               auto& d = self.cast<io::PlyData&>();
                               // Shares the PlyData's cloud: aliasing shared_ptr keeps it alive.
                               auto owner = self.cast<std::shared_ptr<io::PlyData>>();
                               return std::shared_ptr<PointCloud>(owner, &d.cloud);
                             })
      .def_property_readonly("triangles",
                             [](py::object self) {
                               auto& d = self.cast<io::PlyData&>();
                               py::ssize_t n = static_cast<py::ssize_t>(d.triangles.size());
                               return py::array(py::dtype::of<int32_t>(), {n, py::ssize_t{3}},
                                                {py::ssize_t{12}, py::ssize_t{4}},
                                                n ? d.triangles.front().data() : nullptr, self);
                             })
      .def_property_readonly(
          "grid_index",
          [](py::object self) -> py::object {
            auto& d = self.cast<io::PlyData&>();
            if (d.grid_index.empty()) return py::none();
            return ViewVector(d.grid_index, {static_cast<py::ssize_t>(d.grid_index.size())}, self);
          })
      .def_property_readonly("grid_shape",
                             [](const io::PlyData& d) -> py::object {
                               if (d.header.grid_width <= 0) return py::none();
                               return py::make_tuple(d.header.grid_height, d.header.grid_width);
                             })
      .def_property_readonly("comments", [](const io::PlyData& d) { return d.header.comments; })
      .def_property_readonly("format", [](const io::PlyData& d) { return d.header.format; });

  m.def(
      "read_image",
      [](const std::filesystem::path& path, bool float32) {
        cv::Mat image;
        {
          py::gil_scoped_release release;
          image = float32 ? io::ReadFloatImage(path) : io::ReadGrayImage(path);
        }
        return ArrayFromMat(image);
      },
      py::arg("path"), py::arg("float32") = false,
      "Reads a grey image (uint8 or uint16; colour converted to grey), or with float32=True a\n"
      "single-channel float TIFF (the maps `fringe decode` writes).");
  m.def(
      "write_image",
      [](const std::filesystem::path& path, const py::array& image) {
        ImageStack stack = ImagesFromPython(py::make_tuple(image), "image");
        py::gil_scoped_release release;
        io::WriteImage(path, stack.mats[0]);
      },
      py::arg("path"), py::arg("image"),
      "Writes a uint8/uint16 image atomically; the format follows the extension.");
  m.def(
      "read_ply",
      [](const std::filesystem::path& path) {
        auto data = std::make_shared<io::PlyData>();
        {
          py::gil_scoped_release release;
          *data = io::ReadPly(path);
        }
        return data;
      },
      py::arg("path"),
      "Reads an ASCII or binary PLY file (vertices with their attributes, faces, fringe's grid).");
  m.def(
      "write_ply",
      [](const std::filesystem::path& path, const PointCloud& cloud, const py::object& triangles,
         bool ascii, const std::vector<std::string>& comments) {
        WriteCloudOrMesh(path, cloud, triangles, ascii, comments);
      },
      py::arg("path"), py::arg("cloud"), py::arg("triangles") = py::none(),
      py::arg("ascii") = false, py::arg("comments") = std::vector<std::string>{},
      "Writes a PointCloud atomically, binary little-endian or ASCII. With triangles (M, 3) it is\n"
      "written as a mesh: vertices with normals and colours (intensity and quality are refused).");
  m.def(
      "write_ply",
      [](const std::filesystem::path& path, const py::array& points, const py::object& normals,
         const py::object& colors, const py::object& intensity, const py::object& quality,
         const py::object& triangles, bool ascii, const std::vector<std::string>& comments) {
        const PointCloud cloud = CloudFromArrays(points, normals, colors, intensity, quality);
        WriteCloudOrMesh(path, cloud, triangles, ascii, comments);
      },
      py::arg("path"), py::arg("points"), py::arg("normals") = py::none(),
      py::arg("colors") = py::none(), py::arg("intensity") = py::none(),
      py::arg("quality") = py::none(), py::arg("triangles") = py::none(), py::arg("ascii") = false,
      py::arg("comments") = std::vector<std::string>{},
      "Writes points (N, 3) with optional per-point attributes as a PLY file.");
}

}  // namespace fringe::python
