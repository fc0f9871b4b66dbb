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

py::object Vec(const Eigen::Vector3d& v) {
  return py::cast(std::vector<double>{v.x(), v.y(), v.z()});
}

py::dict SphereDict(const eval::SphereResult& r) {
  py::dict d;
  d["status"] = eval::ToString(r.status);
  d["message"] = r.message;
  d["centre_mm"] = Vec(r.centre);
  d["diameter_mm"] = r.diameter_mm;
  d["PF_mm"] = r.PF_mm;
  d["PS_mm"] = r.PS_mm;
  d["rms_mm"] = r.rms_mm;
  d["points"] = r.points;
  d["discarded"] = r.discarded;
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
      .def(py::init([](py::kwargs kw) {
        return MakeOptions<eval::VdiOptions>(py::none(), kw, "VdiOptions");
      }))
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
        return SphereDict(r);
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
        py::dict d;
        d["status"] = eval::ToString(r.status);
        d["message"] = r.message;
        d["sphere_a"] = SphereDict(r.sphere_a);
        d["sphere_b"] = SphereDict(r.sphere_b);
        d["distance_mm"] = r.distance_mm;
        d["SD_mm"] = r.SD_mm;
        d["report"] = r.BriefReport();
        return d;
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
        py::dict d;
        d["status"] = eval::ToString(r.status);
        d["message"] = r.message;
        d["normal"] = Vec(r.normal);
        d["F_mm"] = r.F_mm;
        d["rms_mm"] = r.rms_mm;
        d["points"] = r.points;
        d["discarded"] = r.discarded;
        d["report"] = r.BriefReport();
        return d;
      },
      py::arg("points"), py::arg("options") = py::none(),
      "Finds the dominant plane and returns its flatness F (dict).");

  m.def(
      "deviation",
      [](const py::object& points, const py::object& mesh, double max_distance_mm) {
        eval::DeviationOptions opts;
        opts.max_distance_mm = max_distance_mm;
        opts.Check();
        std::vector<Eigen::Vector3d> vertices;
        std::vector<std::array<int32_t, 3>> triangles;
        if (py::isinstance<io::PlyData>(mesh)) {
          const auto& ply = mesh.cast<const io::PlyData&>();
          vertices = ply.cloud.points;
          triangles = ply.triangles;
        } else if (py::isinstance<py::tuple>(mesh) && py::len(mesh) == 2) {
          auto t = mesh.cast<py::tuple>();
          vertices = PointsFromPython(t[0], "mesh vertices", false);
          auto a = py::array_t<int32_t, py::array::c_style | py::array::forcecast>::ensure(t[1]);
          if (!a || a.ndim() != 2 || a.shape(1) != 3) {
            PyErr_Clear();
            throw py::value_error("mesh triangles: expected an integer array of shape (M, 3)");
          }
          triangles.resize(static_cast<size_t>(a.shape(0)));
          if (!triangles.empty())
            std::copy(a.data(), a.data() + a.size(), triangles.front().data());
        } else {
          throw py::type_error(
              "mesh: expected a PlyFile (fringe.read_ply) or (vertices (V, 3), triangles (M, 3))");
        }
        if (triangles.empty()) throw py::value_error("mesh: no triangles");
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
          const eval::MeshDistance distance(std::move(vertices), std::move(triangles));
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
        py::dict d;
        d["points"] = stats.points;
        d["unmatched"] = stats.unmatched;
        d["mean_mm"] = stats.mean_mm;
        d["rms_mm"] = stats.rms_mm;
        d["p95_mm"] = stats.p95_mm;
        d["max_mm"] = stats.max_mm;
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
