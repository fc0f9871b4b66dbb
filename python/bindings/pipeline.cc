// The whole scanner: a scan folder in, views reconstructed (and later stages) and a report out.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.h"
#include "convert.h"
#include "fringe/pipeline/reconstruct.h"
#include "fringe/pipeline/scan.h"

namespace fringe::python {

namespace {

// "name=value" lines of every public field of a bound options object, nested options expanded
// (their types are the module's own classes), `resume` left out.
std::string OptionsText(const py::object& options, const std::string& prefix) {
  std::string text;
  for (const py::handle& name_handle : py::module_::import("builtins").attr("dir")(options)) {
    const std::string name = py::str(name_handle);
    if (name.empty() || name[0] == '_' || (prefix.empty() && name == "resume")) continue;
    const py::object value = options.attr(name_handle);
    if (PyCallable_Check(value.ptr())) continue;
    const py::object type_module = py::type::of(value).attr("__module__");
    if (py::str(type_module).cast<std::string>().rfind("fringe", 0) == 0 &&
        !py::hasattr(value, "__members__") && !py::isinstance<py::int_>(value)) {
      text += OptionsText(value, prefix + name + ".");
    } else {
      text += prefix + name + "=" + py::repr(value).cast<std::string>() + "\n";
    }
  }
  return text;
}

}  // namespace

void BindPipeline(py::module_& m) {
  py::class_<pipeline::ScanOptions>(m, "ScannerOptions", "Options of fringe.scan (C++ defaults).")
      .def(OptionsInit<pipeline::ScanOptions>("ScannerOptions"))
      .def_readwrite("calib", &pipeline::ScanOptions::calib)
      .def_readwrite("opencv", &pipeline::ScanOptions::opencv)
      .def_readwrite("opencv_keys", &pipeline::ScanOptions::opencv_keys)
      .def_readwrite("opencv_intrinsics", &pipeline::ScanOptions::opencv_intrinsics)
      .def_readwrite("opencv_extrinsics", &pipeline::ScanOptions::opencv_extrinsics)
      .def_readwrite("keep_going", &pipeline::ScanOptions::keep_going)
      .def_readwrite("resume", &pipeline::ScanOptions::resume)
      .def_readwrite("views_in_flight", &pipeline::ScanOptions::views_in_flight)
      .def_readwrite("memory_limit_gib", &pipeline::ScanOptions::memory_limit_gib)
      .def_readwrite("fusion_tile_mm", &pipeline::ScanOptions::fusion_tile_mm)
      .def_readwrite("reconstruction", &pipeline::ScanOptions::reconstruction)
      .def_readwrite("detect_markers", &pipeline::ScanOptions::detect_markers)
      .def_readwrite("markers", &pipeline::ScanOptions::markers)
      .def_readwrite("fit_projector_columns", &pipeline::ScanOptions::fit_projector_columns)
      .def_readwrite("registration", &pipeline::ScanOptions::registration)
      .def_readwrite("fusion", &pipeline::ScanOptions::fusion)
      .def_readwrite("mesh", &pipeline::ScanOptions::mesh)
      .def_readwrite("evaluate_truth", &pipeline::ScanOptions::evaluate_truth)
      .def_readwrite("write_report", &pipeline::ScanOptions::write_report);

  m.def(
      "scan",
      [](const std::filesystem::path& project, const std::filesystem::path& out,
         const py::object& options, const py::kwargs& kw) {
        auto opts = MakeOptions<pipeline::ScanOptions>(options, kw, "ScannerOptions");
        // The views' checkpoints are keyed by the options that change the result (as the CLI's
        // arguments): every field of the options, nested ones included, less resume itself.
        opts.resume_key = OptionsText(py::cast(opts), "");
        pipeline::ScanSummary s;
        {
          py::gil_scoped_release release;
          s = pipeline::RunScan(project, out, opts);
        }
        return FromJson(ToJson(s));
      },
      py::arg("project"), py::arg("out"), py::arg("options") = py::none(),
      "Runs the whole scanner on a scan folder (as `fringe scan PROJECT --out OUT`): calibration\n"
      "if needed, every view reconstructed to OUT/views/NNN.ply, OUT/summary.json and "
      "report.html.\n"
      "Returns the summary (the JSON `fringe scan --json` prints). Options: a ScannerOptions "
      "and/or\n"
      "its fields as keyword arguments (calib=path, keep_going=True, reconstruction={...}).");

  using pipeline::ReconstructFolderOptions;
  py::class_<ReconstructFolderOptions>(m, "ReconstructFolderOptions",
                                       "Options of fringe.reconstruct_folder (C++ defaults).")
      .def(OptionsInit<ReconstructFolderOptions>("ReconstructFolderOptions"))
      .def_readwrite("calib", &ReconstructFolderOptions::calib)
      .def_readwrite("opencv", &ReconstructFolderOptions::opencv)
      .def_readwrite("opencv_keys", &ReconstructFolderOptions::opencv_keys)
      .def_readwrite("opencv_intrinsics", &ReconstructFolderOptions::opencv_intrinsics)
      .def_readwrite("opencv_extrinsics", &ReconstructFolderOptions::opencv_extrinsics)
      .def_property(
          "mode", [](const ReconstructFolderOptions& o) { return pipeline::ToString(o.mode); },
          [](ReconstructFolderOptions& o, const std::string& name) {
            o.mode = pipeline::ReconstructModeFromString(name);
          },
          "auto, stereo, camera-projector or trinocular")
      .def_readwrite("scheme", &ReconstructFolderOptions::scheme)
      .def_readwrite("bit_depth", &ReconstructFolderOptions::bit_depth)
      .def_readwrite("reconstruction", &ReconstructFolderOptions::reconstruction)
      .def_readwrite("detect_markers", &ReconstructFolderOptions::detect_markers)
      .def_readwrite("ascii_ply", &ReconstructFolderOptions::ascii_ply)
      .def_readwrite("residuals", &ReconstructFolderOptions::residuals);

  m.def(
      "reconstruct_folder",
      [](const std::filesystem::path& view, const std::filesystem::path& out,
         const py::object& options, const py::kwargs& kw) {
        const auto opts =
            MakeOptions<ReconstructFolderOptions>(options, kw, "ReconstructFolderOptions");
        pipeline::ViewFolderReconstruction r;
        {
          py::gil_scoped_release release;
          r = pipeline::ReconstructViewFolder(view, out, opts);
        }
        nlohmann::json j = ToJson(r);
        j["report"] = r.report;
        return FromJson(j);
      },
      py::arg("view"), py::arg("out"), py::arg("options") = py::none(),
      "Reconstructs one view folder (as `fringe reconstruct VIEW --out OUT`): left/ and right/\n"
      "stacks (or one camera's with a calibrated projector) to the organized cloud OUT (.ply),\n"
      "OUT.markers.json beside it, and the residual TIFF when `residuals` names one. The scheme\n"
      "and the calibration are found as the command finds them (a scheme preset's parameters\n"
      "are the command's flags only: give a scheme file instead). Returns the JSON\n"
      "`fringe reconstruct --json` prints, with the text report's lines as \"report\".");
}

}  // namespace fringe::python
