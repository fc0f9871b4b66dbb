// Calibration of one camera or a stereo pair from board images.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>

#include "bindings.h"
#include "convert.h"
#include "fringe/calib/calibrate_folder.h"

namespace fringe::python {

namespace {

py::dict SummaryDict(const calib::CalibrationSummary& s) {
  py::dict d;
  d["success"] = s.success;
  d["message"] = s.message;
  d["iterations"] = s.iterations;
  d["initial_rms_px"] = s.initial_rms_px;
  d["final_rms_px"] = s.final_rms_px;
  d["views_used"] = s.num_views_used;
  d["views_rejected"] = s.num_views_rejected;
  d["features"] = s.num_features;
  py::list views;
  for (const auto& v : s.views) {
    py::dict vd;
    vd["name"] = v.name;
    vd["features"] = v.num_features;
    vd["rms_px"] = v.rms_px;
    vd["max_px"] = v.max_px;
    vd["used"] = v.used;
    views.append(vd);
  }
  d["views"] = views;
  d["report"] = s.BriefReport();
  return d;
}

// (rig, summary): a single camera's rig has the camera on both sides and no baseline; its
// summary says "stereo": False.
py::tuple Result(const calib::FolderCalibration& r) {
  if (r.stereo) {
    py::dict d = SummaryDict(r.pair.summary);
    d["stereo"] = true;
    d["rms_px"] = r.pair.rms_px;
    d["epipolar_rms_px"] = r.pair.epipolar_rms_px;
    d["epipolar_max_px"] = r.pair.epipolar_max_px;
    d["pairs"] = r.pair.num_pairs;
    d["left"] = SummaryDict(r.pair.left.summary);
    d["right"] = SummaryDict(r.pair.right.summary);
    d["report"] = r.Report();
    return py::make_tuple(r.pair.rig, d);
  }
  py::dict d = SummaryDict(r.mono.summary);
  d["stereo"] = false;
  d["rms_px"] = r.mono.summary.final_rms_px;
  d["report"] = r.Report();
  return py::make_tuple(py::cast(r.mono.camera), d);
}

}  // namespace

void BindCalib(py::module_& m) {
  py::class_<calib::CalibrationOptions>(m, "CalibrationOptions",
                                        "Options of fringe.calibrate (C++ defaults).")
      .def(py::init([](py::kwargs kw) {
        return MakeOptions<calib::CalibrationOptions>(py::none(), kw, "CalibrationOptions");
      }))
      .def_readwrite("estimate_k3", &calib::CalibrationOptions::estimate_k3)
      .def_readwrite("estimate_tangential", &calib::CalibrationOptions::estimate_tangential)
      .def_readwrite("max_iterations", &calib::CalibrationOptions::max_iterations)
      .def_readwrite("centre_rounds", &calib::CalibrationOptions::centre_rounds)
      .def_readwrite("max_image_rms_px", &calib::CalibrationOptions::max_image_rms_px)
      .def_readwrite("outlier_sigma", &calib::CalibrationOptions::outlier_sigma)
      .def_readwrite("min_features", &calib::CalibrationOptions::min_features)
      .def_readwrite("min_views", &calib::CalibrationOptions::min_views);

  m.def(
      "calibrate",
      [](const py::object& images_or_dir, const CalibrationTarget& target,
         const py::object& options, const py::kwargs& kw) {
        const auto opts = MakeOptions<calib::CalibrationOptions>(options, kw, "CalibrationOptions");
        calib::FolderCalibration r;
        if (py::isinstance<py::str>(images_or_dir) ||
            py::isinstance(images_or_dir, py::module_::import("os").attr("PathLike"))) {
          const auto dir = images_or_dir.cast<std::filesystem::path>();
          {
            py::gil_scoped_release release;
            r = calib::CalibrateFolder(dir, target, opts);
          }
          return Result(r);
        }
        // In memory: a list of one camera's images, or a (left_images, right_images) pair.
        const bool stereo = py::isinstance<py::tuple>(images_or_dir) && py::len(images_or_dir) == 2;
        const py::object left_images =
            stereo ? py::object(images_or_dir.cast<py::tuple>()[0]) : images_or_dir;
        ImageStack left = ImagesFromPython(left_images, "left");
        ImageStack right;
        if (stereo)
          right = ImagesFromPython(py::object(images_or_dir.cast<py::tuple>()[1]), "right");
        if (left.mats.empty()) throw py::value_error("calibrate: no images");
        if (stereo && right.mats.size() != left.mats.size()) {
          throw py::value_error("calibrate: left and right need the same number of images");
        }
        const int width = left.mats[0].cols, height = left.mats[0].rows;
        for (size_t i = 0; i < left.mats.size(); ++i) {
          for (const cv::Mat* img : {&left.mats[i], stereo ? &right.mats[i] : nullptr}) {
            if (img && img->size() != left.mats[0].size()) {
              throw py::value_error("calibrate: image " + std::to_string(i) +
                                    " differs in size from image 0");
            }
          }
          r.names.push_back(std::to_string(i));
        }
        r.stereo = stereo;
        {
          py::gil_scoped_release release;
          for (size_t i = 0; i < left.mats.size(); ++i) {
            r.left.push_back(calib::DetectTarget(left.mats[i], target));
            if (stereo) r.right.push_back(calib::DetectTarget(right.mats[i], target));
          }
          if (stereo) {
            r.pair = calib::CalibrateStereo(r.left, r.right, target, width, height, opts, r.names);
          } else {
            r.mono = calib::CalibrateCamera(r.left, target, width, height, opts, r.names);
          }
        }
        return Result(r);
      },
      py::arg("images_or_dir"), py::arg("target"), py::arg("options") = py::none(),
      "Calibrates from board images: a folder (as `fringe calibrate`: left/ and right/ or one\n"
      "camera's images), a list of one camera's images or a (left_images, right_images) tuple.\n"
      "Returns (Rig, summary) for a pair and (Camera, summary) for one camera.");
}

}  // namespace fringe::python
