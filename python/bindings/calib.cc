// Calibration of one camera or a stereo pair from board images.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>

#include "bindings.h"
#include "convert.h"
#include "fringe/calib/calibrate_folder.h"
#include "fringe/calib/projector_folder.h"

namespace fringe::python {

namespace {

// (rig, summary): the summary is the "calibration" object `fringe calibrate` writes into the
// rig file, with stereo, success, message and the readable report beside it.
py::tuple Result(const calib::FolderCalibration& r) {
  py::dict d = FromJson(calib::CalibrationToJson(r)).cast<py::dict>();
  d["stereo"] = r.stereo;
  d["success"] = r.success();
  d["message"] = r.stereo ? r.pair.summary.message : r.mono.summary.message;
  d["report"] = r.Report();
  if (r.stereo) return py::make_tuple(r.pair.rig, d);
  return py::make_tuple(py::cast(r.mono.camera), d);
}

// DetectionOptions from an options object or a dict of its fields.
calib::DetectionOptions DetectionFrom(const py::object& detection_options) {
  py::dict detection_kw;
  py::object detection_base = py::none();
  if (py::isinstance<py::dict>(detection_options)) {
    detection_kw = py::reinterpret_borrow<py::dict>(detection_options);
  } else {
    detection_base = detection_options;
  }
  return MakeOptions<calib::DetectionOptions>(detection_base, py::kwargs(detection_kw),
                                              "DetectionOptions");
}

}  // namespace

void BindCalib(py::module_& m) {
  py::enum_<calib::RobustLoss>(m, "RobustLoss", "Robust loss of the calibration's residuals.")
      .value("none", calib::RobustLoss::kNone)
      .value("huber", calib::RobustLoss::kHuber)
      .value("cauchy", calib::RobustLoss::kCauchy);
  py::class_<calib::EdgeOptions>(m, "EdgeOptions", "Subpixel edge search of the target detector.")
      .def(OptionsInit<calib::EdgeOptions>("EdgeOptions"))
      .def_readwrite("smoothing_sigma_px", &calib::EdgeOptions::smoothing_sigma_px)
      .def_readwrite("search_half_width_px", &calib::EdgeOptions::search_half_width_px)
      .def_readwrite("min_gradient", &calib::EdgeOptions::min_gradient)
      .def_readwrite("max_angle_deg", &calib::EdgeOptions::max_angle_deg);
  py::class_<calib::EllipseFitOptions>(m, "EllipseFitOptions")
      .def(OptionsInit<calib::EllipseFitOptions>("EllipseFitOptions"))
      .def_readwrite("max_iterations", &calib::EllipseFitOptions::max_iterations)
      .def_readwrite("outlier_sigma", &calib::EllipseFitOptions::outlier_sigma)
      .def_readwrite("min_outlier_dist", &calib::EllipseFitOptions::min_outlier_dist)
      .def_readwrite("outlier_rounds", &calib::EllipseFitOptions::outlier_rounds);
  py::class_<calib::DetectionOptions>(m, "DetectionOptions",
                                      "Options of the calibration target / ring detector.")
      .def(OptionsInit<calib::DetectionOptions>("DetectionOptions"))
      .def_readwrite("edges", &calib::DetectionOptions::edges)
      .def_readwrite("ellipse_fit", &calib::DetectionOptions::ellipse_fit)
      .def_readwrite("min_radius_px", &calib::DetectionOptions::min_radius_px)
      .def_readwrite("max_radius_fraction", &calib::DetectionOptions::max_radius_fraction)
      .def_readwrite("min_axis_ratio", &calib::DetectionOptions::min_axis_ratio)
      .def_readwrite("min_convexity", &calib::DetectionOptions::min_convexity)
      .def_readwrite("max_fit_rms_px", &calib::DetectionOptions::max_fit_rms_px)
      .def_readwrite("min_edge_coverage", &calib::DetectionOptions::min_edge_coverage)
      .def_readwrite("max_concentricity", &calib::DetectionOptions::max_concentricity)
      .def_readwrite("ring_ratio_tolerance", &calib::DetectionOptions::ring_ratio_tolerance)
      .def_readwrite("threshold_levels", &calib::DetectionOptions::threshold_levels)
      .def_readwrite("grid_tolerance", &calib::DetectionOptions::grid_tolerance)
      .def_readwrite("size_tolerance", &calib::DetectionOptions::size_tolerance);

  py::class_<calib::CalibrationOptions>(m, "CalibrationOptions",
                                        "Options of fringe.calibrate (C++ defaults).")
      .def(OptionsInit<calib::CalibrationOptions>("CalibrationOptions"))
      .def_readwrite("estimate_k3", &calib::CalibrationOptions::estimate_k3)
      .def_readwrite("estimate_tangential", &calib::CalibrationOptions::estimate_tangential)
      .def_readwrite("max_iterations", &calib::CalibrationOptions::max_iterations)
      .def_readwrite("centre_rounds", &calib::CalibrationOptions::centre_rounds)
      .def_readwrite("max_image_rms_px", &calib::CalibrationOptions::max_image_rms_px)
      .def_readwrite("outlier_sigma", &calib::CalibrationOptions::outlier_sigma)
      .def_readwrite("min_features", &calib::CalibrationOptions::min_features)
      .def_readwrite("min_views", &calib::CalibrationOptions::min_views)
      .def_readwrite("loss", &calib::CalibrationOptions::loss)
      .def_readwrite("loss_scale_px", &calib::CalibrationOptions::loss_scale_px);

  m.def(
      "calibrate",
      [](const py::object& images_or_dir, const CalibrationTarget& target,
         const py::object& detection_options, const py::object& options, const py::kwargs& kw) {
        const auto opts = MakeOptions<calib::CalibrationOptions>(options, kw, "CalibrationOptions");
        const auto detection = DetectionFrom(detection_options);
        calib::FolderCalibration r;
        if (py::isinstance<py::str>(images_or_dir) ||
            py::isinstance(images_or_dir, py::module_::import("os").attr("PathLike"))) {
          const auto dir = images_or_dir.cast<std::filesystem::path>();
          {
            py::gil_scoped_release release;
            r = calib::CalibrateFolder(dir, target, opts, detection);
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
            r.left.push_back(calib::DetectTarget(left.mats[i], target, detection));
            if (stereo) r.right.push_back(calib::DetectTarget(right.mats[i], target, detection));
          }
          if (stereo) {
            r.pair = calib::CalibrateStereo(r.left, r.right, target, width, height, opts, r.names);
          } else {
            r.mono = calib::CalibrateCamera(r.left, target, width, height, opts, r.names);
          }
        }
        return Result(r);
      },
      py::arg("images_or_dir"), py::arg("target"), py::arg("detection") = py::none(),
      py::arg("options") = py::none(),
      "Calibrates from board images: a folder (as `fringe calibrate`: left/ and right/ or one\n"
      "camera's images), a list of one camera's images or a (left_images, right_images) tuple.\n"
      "detection: DetectionOptions or a dict of its fields; options: a CalibrationOptions and/or\n"
      "its fields as keyword arguments.\n"
      "Returns (Rig, summary) for a pair and (Camera, summary) for one camera.");

  py::class_<calib::ProjectorFeatureOptions>(
      m, "ProjectorFeatureOptions",
      "Local homographies mapping board features into the projector (Moreno & Taubin).")
      .def(OptionsInit<calib::ProjectorFeatureOptions>("ProjectorFeatureOptions"))
      .def_readwrite("window_radius_px", &calib::ProjectorFeatureOptions::window_radius_px)
      .def_readwrite("min_points", &calib::ProjectorFeatureOptions::min_points);

  m.def(
      "calibrate_projector",
      [](const std::filesystem::path& dir, const CalibrationTarget& target,
         const py::object& detection_options, const py::object& features, const py::object& options,
         const py::kwargs& kw) {
        calib::ProjectorFolderOptions o;
        o.calibration = MakeOptions<calib::CalibrationOptions>(options, kw, "CalibrationOptions");
        o.detection = DetectionFrom(detection_options);
        if (!features.is_none()) o.features = features.cast<calib::ProjectorFeatureOptions>();
        calib::ProjectorFolderCalibration r;
        {
          py::gil_scoped_release release;
          r = calib::CalibrateProjectorFolder(dir, target, o);
        }
        py::dict d;
        if (r.ok()) d = FromJson(CalibrationToJson(r)).cast<py::dict>();
        d["layout"] = r.layout == calib::ProjectorFolderLayout::kCamerasProjector
                          ? "cameras-projector"
                          : "camera-projector";
        d["success"] = r.ok();
        d["message"] = r.message();
        d["report"] = r.BriefReport();
        d["names"] = r.names;
        return py::make_tuple(r.rig, d);
      },
      py::arg("dir"), py::arg("target"), py::arg("detection") = py::none(),
      py::arg("features") = py::none(), py::arg("options") = py::none(),
      "Calibrates camera(s) + projector from board pose folders, as `fringe calibrate DIR` when\n"
      "DIR holds fringe stacks: DIR/KKK/{board image, vertical/, horizontal/} (one camera) or\n"
      "DIR/KKK/left/... and DIR/KKK/right/... (two cameras), each stack with its manifest.json.\n"
      "detection: DetectionOptions or a dict; features: ProjectorFeatureOptions; options: a\n"
      "CalibrationOptions and/or its fields as keyword arguments.\n"
      "Returns (Rig, summary): the rig with its projector (no right camera for one camera) and\n"
      "the 'calibration' object `fringe calibrate` writes, with layout, success, message, report.");
}

}  // namespace fringe::python
