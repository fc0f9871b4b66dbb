// One stereo view to 3D: options, the reconstructor and its result.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.h"
#include "convert.h"
#include "fringe/io/ply.h"
#include "fringe/phase/stack_io.h"
#include "fringe/stereo/camera_projector.h"
#include "fringe/stereo/reconstruct_view.h"
#include "fringe/util/error.h"

namespace fringe::python {

namespace {

using ViewPtr = std::shared_ptr<stereo::ViewReconstruction>;

ViewPtr Run(const stereo::ViewReconstructor& r, const py::object& left, const py::object& right) {
  ImageStack l = ImagesFromPython(left, "left");
  ImageStack rr = ImagesFromPython(right, "right");
  auto view = std::make_shared<stereo::ViewReconstruction>();
  py::gil_scoped_release release;
  *view = r.Reconstruct(l.mats, rr.mats);
  return view;
}

// Camera + projector (issue 14): the rig's left camera against its calibrated projector, one
// stack per scheme (one fringe direction, or one of each).
ViewPtr RunCameraProjector(const StereoRig& rig, const std::vector<phase::PatternScheme>& schemes,
                           const std::vector<py::object>& stacks,
                           const stereo::ReconstructionOptions& options) {
  if (stacks.size() != schemes.size()) {
    throw Error(util::StrCat("reconstruct_camera_projector: ", schemes.size(), " scheme(s) but ",
                             stacks.size(), " stack(s)"));
  }
  std::vector<ImageStack> held;
  for (size_t i = 0; i < stacks.size(); ++i) {
    held.push_back(ImagesFromPython(stacks[i], util::StrCat("stack ", i)));
  }
  std::vector<std::vector<cv::Mat>> mats;
  for (const auto& h : held) mats.push_back(h.mats);
  auto view = std::make_shared<stereo::ViewReconstruction>();
  py::gil_scoped_release release;
  const stereo::ViewReconstructor r = stereo::MakeCameraProjectorReconstructor(
      stereo::CameraProjectorRig::FromLeftCamera(rig), schemes, options);
  *view = r.Reconstruct(stereo::ViewStacks{mats, {}});
  return view;
}

}  // namespace

void BindStereo(py::module_& m) {
  py::enum_<stereo::CrossingInterpolation>(m, "CrossingInterpolation")
      .value("linear", stereo::CrossingInterpolation::kLinear)
      .value("cubic", stereo::CrossingInterpolation::kCubic);

  py::class_<stereo::TriangulationOptions>(m, "TriangulationOptions")
      .def(OptionsInit<stereo::TriangulationOptions>("TriangulationOptions"))
      .def_readwrite("refine_iterations", &stereo::TriangulationOptions::refine_iterations)
      .def_readwrite("min_ray_angle_rad", &stereo::TriangulationOptions::min_ray_angle_rad);
  py::class_<stereo::RectificationOptions>(m, "RectificationOptions")
      .def(OptionsInit<stereo::RectificationOptions>("RectificationOptions"))
      .def_readwrite("focal_scale", &stereo::RectificationOptions::focal_scale);
  py::class_<stereo::MatchingOptions>(m, "MatchingOptions")
      .def(OptionsInit<stereo::MatchingOptions>("MatchingOptions"))
      .def_readwrite("min_modulation", &stereo::MatchingOptions::min_modulation)
      .def_readwrite("max_step_gradients", &stereo::MatchingOptions::max_step_gradients)
      .def_readwrite("max_reversal_gradients", &stereo::MatchingOptions::max_reversal_gradients)
      .def_readwrite("interpolation", &stereo::MatchingOptions::interpolation)
      .def_readwrite("max_row_crossing_diff_px", &stereo::MatchingOptions::max_row_crossing_diff_px)
      .def_readwrite("max_lr_error_px", &stereo::MatchingOptions::max_lr_error_px)
      .def_readwrite("max_reprojection_error_px",
                     &stereo::MatchingOptions::max_reprojection_error_px)
      .def_readwrite("max_projector_error_px", &stereo::MatchingOptions::max_projector_error_px)
      .def_readwrite("lr_warning_fraction", &stereo::MatchingOptions::lr_warning_fraction)
      .def_readwrite("min_depth_mm", &stereo::MatchingOptions::min_depth_mm)
      .def_readwrite("max_depth_mm", &stereo::MatchingOptions::max_depth_mm)
      .def_readwrite("triangulation", &stereo::MatchingOptions::triangulation)
      .def_readwrite("rectification", &stereo::MatchingOptions::rectification);
  py::class_<stereo::OutlierOptions>(m, "OutlierOptions")
      .def(OptionsInit<stereo::OutlierOptions>("OutlierOptions"))
      .def_readwrite("max_slope_factor", &stereo::OutlierOptions::max_slope_factor)
      .def_readwrite("min_neighbours", &stereo::OutlierOptions::min_neighbours)
      .def_readwrite("min_component_px", &stereo::OutlierOptions::min_component_px);
  py::class_<GridNormalOptions>(m, "GridNormalOptions")
      .def(OptionsInit<GridNormalOptions>("GridNormalOptions"))
      .def_readwrite("window_radius_px", &GridNormalOptions::window_radius_px)
      .def_readwrite("max_depth_jump_mm", &GridNormalOptions::max_depth_jump_mm)
      .def_readwrite("relative_depth_jump", &GridNormalOptions::relative_depth_jump)
      .def_readwrite("min_points", &GridNormalOptions::min_points);
  py::class_<stereo::ReconstructionOptions>(m, "ReconstructionOptions", R"doc(
Options of fringe.reconstruct: nested decode/matching/outliers/normals options (objects or
dicts of their fields) and the remove_outliers / compute_normals switches.)doc")
      .def(OptionsInit<stereo::ReconstructionOptions>("ReconstructionOptions"))
      .def_readwrite("decode", &stereo::ReconstructionOptions::decode)
      .def_readwrite("matching", &stereo::ReconstructionOptions::matching)
      .def_readwrite("remove_outliers", &stereo::ReconstructionOptions::remove_outliers)
      .def_readwrite("outliers", &stereo::ReconstructionOptions::outliers)
      .def_readwrite("compute_normals", &stereo::ReconstructionOptions::compute_normals)
      .def_readwrite("normals", &stereo::ReconstructionOptions::normals);

  py::class_<stereo::ViewReconstruction, ViewPtr>(m, "ViewReconstruction", R"doc(
One view in 3D, on the LEFT camera grid, in the LEFT camera frame (mm). Arrays view the C++
result (no copy): points (H, W, 3) float64 with NaN where empty, normals (H, W, 3) (NaN where
none), valid (H, W) bool, quality (H, W) float32 (left modulation, DN), intensity (H, W) float32
(left texture, 0-255), reprojection_error_px (H, W) float32, texture_left / texture_right;
summary is a dict; cloud() gives the valid points as a PointCloud.)doc")
      .def_property_readonly("width",
                             [](const stereo::ViewReconstruction& v) { return v.cloud.width; })
      .def_property_readonly("height",
                             [](const stereo::ViewReconstruction& v) { return v.cloud.height; })
      .def_property_readonly(
          "points",
          [](py::object self) {
            auto& v = self.cast<stereo::ViewReconstruction&>();
            return ViewVec3(v.cloud.cloud.points, {v.cloud.height, v.cloud.width}, self);
          })
      .def_property_readonly(
          "normals",
          [](py::object self) -> py::object {
            auto& v = self.cast<stereo::ViewReconstruction&>();
            if (!v.cloud.cloud.has_normals()) return py::none();
            return ViewVec3(v.cloud.cloud.normals, {v.cloud.height, v.cloud.width}, self);
          })
      .def_property_readonly("valid",
                             [](py::object self) {
                               // Entries are 0 or 1, so the bytes are valid numpy booleans.
                               auto& v = self.cast<stereo::ViewReconstruction&>();
                               return py::array(
                                   py::dtype("bool"), {v.cloud.height, v.cloud.width},
                                   {static_cast<py::ssize_t>(v.cloud.width), py::ssize_t{1}},
                                   v.cloud.valid.data(), self);
                             })
      .def_property_readonly(
          "quality",
          [](py::object self) -> py::object {
            auto& v = self.cast<stereo::ViewReconstruction&>();
            if (!v.cloud.cloud.has_quality()) return py::none();
            return ViewVector(v.cloud.cloud.quality, {v.cloud.height, v.cloud.width}, self);
          })
      .def_property_readonly(
          "intensity",
          [](py::object self) -> py::object {
            auto& v = self.cast<stereo::ViewReconstruction&>();
            if (!v.cloud.cloud.has_intensity()) return py::none();
            return ViewVector(v.cloud.cloud.intensity, {v.cloud.height, v.cloud.width}, self);
          })
      .def_property_readonly(
          "reprojection_error_px",
          [](const stereo::ViewReconstruction& v) { return ArrayFromMat(v.reprojection_error_px); })
      .def_property_readonly(
          "texture_left",
          [](const stereo::ViewReconstruction& v) { return ArrayFromMat(v.texture_left); })
      .def_property_readonly(
          "texture_right",
          [](const stereo::ViewReconstruction& v) { return ArrayFromMat(v.texture_right); })
      .def_property_readonly(
          "summary",
          [](const stereo::ViewReconstruction& v) { return FromJson(stereo::ToJson(v.summary)); })
      .def_property_readonly("ok",
                             [](const stereo::ViewReconstruction& v) { return v.summary.ok(); })
      .def(
          "cloud",
          [](const stereo::ViewReconstruction& v) {
            return std::make_shared<PointCloud>(v.cloud.Compact());
          },
          "The valid points (grid order) as a PointCloud (a copy).")
      .def("brief_report",
           [](const stereo::ViewReconstruction& v) { return v.summary.BriefReport(); })
      .def("__repr__", [](const stereo::ViewReconstruction& v) {
        return "fringe.ViewReconstruction(" + v.summary.BriefReport() + ")";
      });

  py::class_<stereo::ViewReconstructor>(m, "Reconstructor", R"doc(
Reusable stereo reconstructor for one rig and scheme (rectification and matcher set up once);
reconstruct(left, right) may be called from several threads.)doc")
      .def(py::init([](const StereoRig& rig, const phase::PatternScheme& scheme,
                       const py::object& options, const py::kwargs& kwargs) {
             const auto opts = MakeOptions<stereo::ReconstructionOptions>(options, kwargs,
                                                                          "ReconstructionOptions");
             return std::make_unique<stereo::ViewReconstructor>(rig, scheme, opts);
           }),
           py::arg("rig"), py::arg("scheme"), py::arg("options") = py::none())
      .def("reconstruct", &Run, py::arg("left"), py::arg("right"),
           "Left and right stacks (uint8/uint16, the scheme's order) to a ViewReconstruction.");

  m.def(
      "reconstruct",
      [](const StereoRig& rig, const phase::PatternScheme& scheme, const py::object& left,
         const py::object& right, const py::object& options, const py::kwargs& kwargs) {
        const auto opts =
            MakeOptions<stereo::ReconstructionOptions>(options, kwargs, "ReconstructionOptions");
        if (right.is_none()) return RunCameraProjector(rig, {scheme}, {left}, opts);
        std::unique_ptr<stereo::ViewReconstructor> r;
        {
          py::gil_scoped_release release;
          r = std::make_unique<stereo::ViewReconstructor>(rig, scheme, opts);
        }
        return Run(*r, left, right);
      },
      py::arg("rig"), py::arg("scheme"), py::arg("left"), py::arg("right") = py::none(),
      py::arg("options") = py::none(),
      "One view to 3D (as `fringe reconstruct`): left and right stacks in stereo mode; with\n"
      "right=None the left camera against the rig's calibrated projector (camera-projector\n"
      "mode, as `fringe reconstruct --mode camera-projector`). Options: a ReconstructionOptions\n"
      "and/or its fields as keyword arguments (nested options as dicts, e.g.\n"
      "decode={'noise_sigma_dn': 3}).");

  m.def(
      "reconstruct_camera_projector",
      [](const StereoRig& rig, const std::vector<phase::PatternScheme>& schemes,
         const std::vector<py::object>& stacks, const py::object& options,
         const py::kwargs& kwargs) {
        const auto opts =
            MakeOptions<stereo::ReconstructionOptions>(options, kwargs, "ReconstructionOptions");
        return RunCameraProjector(rig, schemes, stacks, opts);
      },
      py::arg("rig"), py::arg("schemes"), py::arg("stacks"), py::arg("options") = py::none(),
      "One camera against the rig's calibrated projector with one stack per scheme: one fringe\n"
      "direction (ray against the projector column or row, exact in the distorted model) or one\n"
      "stack of each direction (two-ray triangulation). The cloud is on the camera grid, camera\n"
      "frame, mm; residuals are the round trip into the projector (px).");

  m.def(
      "write_ply",
      [](const std::filesystem::path& path, const stereo::ViewReconstruction& view, bool ascii,
         const std::vector<std::string>& comments) {
        py::gil_scoped_release release;
        io::WritePly(path, view.cloud,
                     ascii ? io::PlyFormat::kAscii : io::PlyFormat::kBinaryLittleEndian, comments);
      },
      py::arg("path"), py::arg("view"), py::arg("ascii") = false,
      py::arg("comments") = std::vector<std::string>{},
      "Writes a view's organized cloud (grid kept, as `fringe reconstruct` writes it).");
}

}  // namespace fringe::python
