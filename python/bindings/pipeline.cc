// The whole scanner: a scan folder in, views reconstructed (and later stages) and a report out.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.h"
#include "convert.h"
#include "fringe/pipeline/scan.h"

namespace fringe::python {

void BindPipeline(py::module_& m) {
  py::class_<pipeline::ScanOptions>(m, "ScannerOptions", "Options of fringe.scan (C++ defaults).")
      .def(OptionsInit<pipeline::ScanOptions>("ScannerOptions"))
      .def_readwrite("calib", &pipeline::ScanOptions::calib)
      .def_readwrite("opencv_intrinsics", &pipeline::ScanOptions::opencv_intrinsics)
      .def_readwrite("opencv_extrinsics", &pipeline::ScanOptions::opencv_extrinsics)
      .def_readwrite("keep_going", &pipeline::ScanOptions::keep_going)
      .def_readwrite("views_in_flight", &pipeline::ScanOptions::views_in_flight)
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
        const auto opts = MakeOptions<pipeline::ScanOptions>(options, kw, "ScannerOptions");
        pipeline::ScanSummary s;
        {
          py::gil_scoped_release release;
          s = pipeline::RunScan(project, out, opts);
        }
        return FromJson(s.ToJson());
      },
      py::arg("project"), py::arg("out"), py::arg("options") = py::none(),
      "Runs the whole scanner on a scan folder (as `fringe scan PROJECT --out OUT`): calibration\n"
      "if needed, every view reconstructed to OUT/views/NNN.ply, OUT/summary.json and "
      "report.html.\n"
      "Returns the summary (the JSON `fringe scan --json` prints). Options: a ScannerOptions "
      "and/or\n"
      "its fields as keyword arguments (calib=path, keep_going=True, reconstruction={...}).");
}

}  // namespace fringe::python
