// VDI/VDE 2634-2 figures and deviation from a reference mesh.
#include <pybind11/stl.h>

#include <limits>

#include "bindings.h"
#include "convert.h"
#include "fringe/eval/deviation.h"
#include "fringe/eval/vdi2634.h"
#include "fringe/io/ply.h"

namespace fringe::python {

namespace {

// The JSON `fringe evaluate --json` prints for the result, plus its one-line report.
template <typename Result>
py::dict ResultDict(const Result& r) {
  py::dict d = FromJson(eval::ToJson(r)).template cast<py::dict>();
  d["report"] = r.BriefReport();
  return d;
}

// Points from a PointCloud or an array (N, 3) / (H, W, 3); NaN rows (empty grid slots) dropped.
PointCloud CloudOf(const py::handle& points) {
  if (py::isinstance<PointCloud>(points)) return points.cast<PointCloud>();
  PointCloud cloud;
  cloud.points = PointsFromPython(points, "points", true);
  return cloud;
}

}  // namespace

void BindEval(py::module_& m) {
  py::class_<eval::VdiOptions>(m, "VdiOptions", "Options of fringe.evaluate.* (C++ defaults).")
      .def(OptionsInit<eval::VdiOptions>("VdiOptions"))
      .def_readwrite("discard_fraction", &eval::VdiOptions::discard_fraction)
      .def_readwrite("inlier_band_mm", &eval::VdiOptions::inlier_band_mm)
      .def_readwrite("ransac_iterations", &eval::VdiOptions::ransac_iterations)
      .def_readwrite("seed", &eval::VdiOptions::seed)
      .def_readwrite("ransac_sample_points", &eval::VdiOptions::ransac_sample_points)
      .def_readwrite("radius_tolerance", &eval::VdiOptions::radius_tolerance)
      .def_readwrite("min_points", &eval::VdiOptions::min_points);

  py::module_ ev = m.def_submodule("evaluate", "VDI/VDE 2634-2 figures of a measured artefact.");
  ev.def(
      "sphere",
      [](const py::object& points, double diameter_mm, const py::object& options,
         const py::kwargs& kw) {
        const auto opts = MakeOptions<eval::VdiOptions>(options, kw, "VdiOptions");
        const PointCloud cloud = CloudOf(points);
        eval::SphereResult r;
        {
          py::gil_scoped_release release;
          r = eval::EvaluateSphere(cloud, diameter_mm, opts);
        }
        return ResultDict(r);
      },
      py::arg("points"), py::arg("diameter_mm"), py::arg("options") = py::none(),
      "Finds the sphere of the calibrated diameter and returns PF, PS (dict, as `fringe "
      "evaluate`).");
  ev.def(
      "ballbar",
      [](const py::object& points, double diameter_mm, double distance_mm,
         const py::object& options, const py::kwargs& kw) {
        const auto opts = MakeOptions<eval::VdiOptions>(options, kw, "VdiOptions");
        const PointCloud cloud = CloudOf(points);
        eval::BallBarResult r;
        {
          py::gil_scoped_release release;
          r = eval::EvaluateBallBar(cloud, diameter_mm, distance_mm, opts);
        }
        return ResultDict(r);
      },
      py::arg("points"), py::arg("diameter_mm"), py::arg("distance_mm"),
      py::arg("options") = py::none(),
      "Finds both spheres of a ball bar and returns the sphere-spacing error SD (dict).");
  ev.def(
      "plane",
      [](const py::object& points, const py::object& options, const py::kwargs& kw) {
        const auto opts = MakeOptions<eval::VdiOptions>(options, kw, "VdiOptions");
        const PointCloud cloud = CloudOf(points);
        eval::PlaneResult r;
        {
          py::gil_scoped_release release;
          r = eval::EvaluatePlane(cloud, opts);
        }
        return ResultDict(r);
      },
      py::arg("points"), py::arg("options") = py::none(),
      "Finds the dominant plane and returns its flatness F (dict).");

  m.def(
      "deviation",
      [](const py::object& points, const py::object& mesh, double max_distance_mm) {
        eval::DeviationOptions opts;
        opts.max_distance_mm = max_distance_mm;
        opts.Check();
        TriangleMesh reference = MeshFromPython(mesh, "mesh");
        if (reference.empty()) throw py::value_error("mesh: no triangles");
        PointCloud cloud;
        const bool organized = !py::isinstance<PointCloud>(points);
        std::vector<size_t> slot;  // input index of each kept point (NaN rows dropped)
        if (organized) {
          auto all = PointsFromPython(points, "points", false);
          for (size_t i = 0; i < all.size(); ++i) {
            if (all[i].allFinite()) {
              cloud.points.push_back(all[i]);
              slot.push_back(i);
            }
          }
        } else {
          cloud = points.cast<PointCloud>();
        }
        std::vector<double> signed_mm;
        eval::DeviationStats stats;
        {
          py::gil_scoped_release release;
          const MeshIndex distance(std::move(reference));
          stats = eval::DeviationFromMesh(cloud, distance, opts, &signed_mm);
        }
        // Signed distances in the input's shape (NaN for empty slots and unmatched points).
        py::array_t<double> distances;
        if (organized) {
          auto in = py::array::ensure(points);
          std::vector<py::ssize_t> shape(in.shape(), in.shape() + in.ndim() - 1);
          distances = py::array_t<double>(shape);
          double* out = distances.mutable_data();
          std::fill(out, out + distances.size(), std::numeric_limits<double>::quiet_NaN());
          for (size_t k = 0; k < slot.size(); ++k) out[slot[k]] = signed_mm[k];
        } else {
          distances =
              py::array_t<double>(static_cast<py::ssize_t>(signed_mm.size()), signed_mm.data());
        }
        py::dict d = FromJson(eval::ToJson(stats)).cast<py::dict>();
        d["report"] = stats.BriefReport();
        return py::make_tuple(d, distances);
      },
      py::arg("points"), py::arg("mesh"),
      py::arg("max_distance_mm") = eval::DeviationOptions{}.max_distance_mm,
      "Signed distances of points (N, 3), (H, W, 3) or a PointCloud from a reference mesh: "
      "returns\n"
      "(stats dict, distances in the input's shape, NaN where empty or farther than "
      "max_distance_mm).");
}

}  // namespace fringe::python
