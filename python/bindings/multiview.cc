// Several views into one model: sticky markers, registration, fusion and meshing.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.h"
#include "convert.h"
#include "fringe/fusion/fuse.h"
#include "fringe/fusion/mesh.h"
#include "fringe/io/ply.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/pose_graph.h"
#include "fringe/registration/register_views.h"
#include "fringe/registration/registration_io.h"
#include "fringe/stereo/reconstruct_view.h"
#include "fringe/util/error.h"

namespace fringe::python {

namespace {

namespace fs = std::filesystem;
using registration::RegistrationResult;

bool IsPath(const py::handle& h) {
  return py::isinstance<py::str>(h) ||
         py::isinstance(h, py::module_::import("os").attr("PathLike"));
}

py::array Vec3Array(const Eigen::Vector3d& v) {
  py::array_t<double> out(3);
  for (int i = 0; i < 3; ++i) out.mutable_at(i) = v[i];
  return out;
}
py::array Vec2Array(const Eigen::Vector2d& v) {
  py::array_t<double> out(2);
  for (int i = 0; i < 2; ++i) out.mutable_at(i) = v[i];
  return out;
}

// Names: the given list, else a path's stem, else "view<i>".
std::vector<std::string> ViewNames(const py::sequence& views, const py::object& names) {
  std::vector<std::string> out;
  if (!names.is_none()) {
    out = names.cast<std::vector<std::string>>();
    if (out.size() != views.size()) {
      throw py::value_error("names: expected one name per view (" + std::to_string(views.size()) +
                            "), got " + std::to_string(out.size()));
    }
    return out;
  }
  for (size_t i = 0; i < views.size(); ++i) {
    out.push_back(IsPath(views[i]) ? views[i].cast<fs::path>().stem().string()
                                   : "view" + std::to_string(i));
  }
  return out;
}

// Poses: a RegistrationResult (every view must be placed) or a list of 4x4 world_from_sensor.
std::vector<Rigid3d> PosesFromPython(const py::object& poses, size_t n) {
  std::vector<Rigid3d> out;
  if (py::isinstance<RegistrationResult>(poses)) {
    const auto& r = poses.cast<const RegistrationResult&>();
    for (const auto& v : r.views) {
      if (!v.placed()) {
        throw py::value_error("poses: view '" + v.name + "' was not placed by the registration (" +
                              registration::ToString(v.path) + ": " + v.message + ")");
      }
      out.push_back(v.world_from_sensor);
    }
  } else {
    const auto list = poses.cast<py::sequence>();
    for (size_t i = 0; i < list.size(); ++i) {
      out.push_back(RigidFromPython(list[i], "poses[" + std::to_string(i) + "]"));
    }
  }
  if (out.size() != n) {
    throw py::value_error("poses: expected one pose per view (" + std::to_string(n) + "), got " +
                          std::to_string(out.size()));
  }
  return out;
}

}  // namespace

void BindMultiView(py::module_& m) {
  // ---- Sticky markers ----
  py::class_<registration::MarkerDetectionOptions>(m, "MarkerDetectionOptions",
                                                   "Options of fringe.detect_markers.")
      .def(OptionsInit<registration::MarkerDetectionOptions>("MarkerDetectionOptions"))
      .def_readwrite("rings", &registration::MarkerDetectionOptions::rings)
      .def_readwrite("inner_to_outer_ratio",
                     &registration::MarkerDetectionOptions::inner_to_outer_ratio)
      .def_readwrite("max_epipolar_px", &registration::MarkerDetectionOptions::max_epipolar_px)
      .def_readwrite("max_depth_difference_mm",
                     &registration::MarkerDetectionOptions::max_depth_difference_mm)
      .def_readwrite("relative_depth_difference",
                     &registration::MarkerDetectionOptions::relative_depth_difference)
      .def_readwrite("min_outer_radius_mm",
                     &registration::MarkerDetectionOptions::min_outer_radius_mm)
      .def_readwrite("max_outer_radius_mm",
                     &registration::MarkerDetectionOptions::max_outer_radius_mm)
      .def_readwrite("surface_radius_factor",
                     &registration::MarkerDetectionOptions::surface_radius_factor)
      .def_readwrite("min_surface_points",
                     &registration::MarkerDetectionOptions::min_surface_points);

  py::class_<registration::ViewMarker>(m, "ViewMarker", R"doc(
A sticky marker measured in one view (sensor = left camera frame, mm): centre_in_sensor and
normal_in_sensor (3,), left_px / right_px (2,), outer_radius_mm, sigma_mm (1-sigma centre
uncertainty), depth_difference_mm.)doc")
      .def_readonly("id", &registration::ViewMarker::id)
      .def_property_readonly(
          "centre_in_sensor",
          [](const registration::ViewMarker& k) { return Vec3Array(k.centre_in_sensor); })
      .def_property_readonly(
          "normal_in_sensor",
          [](const registration::ViewMarker& k) { return Vec3Array(k.normal_in_sensor); })
      .def_property_readonly("left_px",
                             [](const registration::ViewMarker& k) { return Vec2Array(k.left_px); })
      .def_property_readonly(
          "right_px", [](const registration::ViewMarker& k) { return Vec2Array(k.right_px); })
      .def_readonly("outer_radius_mm", &registration::ViewMarker::outer_radius_mm)
      .def_readonly("sigma_mm", &registration::ViewMarker::sigma_mm)
      .def_readonly("depth_difference_mm", &registration::ViewMarker::depth_difference_mm)
      .def("__repr__", [](const registration::ViewMarker& k) {
        return util::StrCat("fringe.ViewMarker(", k.id, ", centre ", k.centre_in_sensor.x(), " ",
                            k.centre_in_sensor.y(), " ", k.centre_in_sensor.z(), " mm)");
      });

  m.def(
      "detect_markers",
      [](const StereoRig& rig, const stereo::ViewReconstruction& view, const py::object& options,
         const py::kwargs& kw) {
        const auto opts = MakeOptions<registration::MarkerDetectionOptions>(
            options, kw, "MarkerDetectionOptions");
        registration::ViewMarkers r;
        {
          py::gil_scoped_release release;
          r = registration::DetectViewMarkers(rig, view.texture_left, view.texture_right,
                                              view.cloud, opts);
        }
        return py::make_tuple(r.markers, r.summary.BriefReport());
      },
      py::arg("rig"), py::arg("view"), py::arg("options") = py::none(),
      "Sticky markers of a reconstructed view (as `fringe reconstruct` finds them): returns\n"
      "(list of ViewMarker, one-line report).");
  m.def(
      "read_markers", [](const fs::path& p) { return registration::ReadViewMarkers(p); },
      py::arg("path"), "Reads a view's markers file (VIEW.markers.json).");
  m.def(
      "write_markers",
      [](const fs::path& p, const std::vector<registration::ViewMarker>& markers) {
        registration::WriteViewMarkers(p, markers);
      },
      py::arg("path"), py::arg("markers"), "Writes a view's markers file atomically.");

  // ---- Registration ----
  py::class_<registration::MarkerMatchOptions>(m, "MarkerMatchOptions")
      .def(OptionsInit<registration::MarkerMatchOptions>("MarkerMatchOptions"))
      .def_readwrite("distance_tolerance_mm",
                     &registration::MarkerMatchOptions::distance_tolerance_mm)
      .def_readwrite("sigma_factor", &registration::MarkerMatchOptions::sigma_factor)
      .def_readwrite("max_normal_angle_deg",
                     &registration::MarkerMatchOptions::max_normal_angle_deg)
      .def_readwrite("min_matches", &registration::MarkerMatchOptions::min_matches)
      .def_readwrite("ambiguity_margin", &registration::MarkerMatchOptions::ambiguity_margin)
      .def_readwrite("same_pose_deg", &registration::MarkerMatchOptions::same_pose_deg)
      .def_readwrite("same_pose_mm", &registration::MarkerMatchOptions::same_pose_mm)
      .def_readwrite("outlier_rounds", &registration::MarkerMatchOptions::outlier_rounds);
  py::class_<registration::AdjustmentOptions>(m, "AdjustmentOptions")
      .def(OptionsInit<registration::AdjustmentOptions>("AdjustmentOptions"))
      .def_readwrite("huber_sigmas", &registration::AdjustmentOptions::huber_sigmas)
      .def_readwrite("max_iterations", &registration::AdjustmentOptions::max_iterations);
  py::class_<registration::CoarseOptions>(m, "CoarseOptions")
      .def(OptionsInit<registration::CoarseOptions>("CoarseOptions"))
      .def_readwrite("voxel_mm", &registration::CoarseOptions::voxel_mm)
      .def_readwrite("feature_radius_factor", &registration::CoarseOptions::feature_radius_factor)
      .def_readwrite("max_ransac_iterations", &registration::CoarseOptions::max_ransac_iterations)
      .def_readwrite("ransac_confidence", &registration::CoarseOptions::ransac_confidence)
      .def_readwrite("min_fitness", &registration::CoarseOptions::min_fitness)
      .def_readwrite("seed", &registration::CoarseOptions::seed);
  py::class_<registration::IcpOptions>(m, "IcpOptions")
      .def(OptionsInit<registration::IcpOptions>("IcpOptions"))
      .def_readwrite("points_per_level", &registration::IcpOptions::points_per_level)
      .def_readwrite("max_iterations_per_level",
                     &registration::IcpOptions::max_iterations_per_level)
      .def_readwrite("initial_threshold_mm", &registration::IcpOptions::initial_threshold_mm)
      .def_readwrite("min_threshold_mm", &registration::IcpOptions::min_threshold_mm)
      .def_readwrite("shrink_factor", &registration::IcpOptions::shrink_factor)
      .def_readwrite("shrink_percentile", &registration::IcpOptions::shrink_percentile)
      .def_readwrite("trim_fraction", &registration::IcpOptions::trim_fraction)
      .def_readwrite("max_normal_angle_deg", &registration::IcpOptions::max_normal_angle_deg)
      .def_readwrite("min_overlap_fraction", &registration::IcpOptions::min_overlap_fraction)
      .def_readwrite("degeneracy_ratio", &registration::IcpOptions::degeneracy_ratio)
      .def_readwrite("convergence_rotation_deg",
                     &registration::IcpOptions::convergence_rotation_deg)
      .def_readwrite("convergence_translation_mm",
                     &registration::IcpOptions::convergence_translation_mm)
      .def_readwrite("seed", &registration::IcpOptions::seed);
  py::class_<registration::PoseGraphOptions>(m, "PoseGraphOptions",
                                             "The marker-free path's cycle check (C++ defaults).")
      .def(OptionsInit<registration::PoseGraphOptions>("PoseGraphOptions"))
      .def_readwrite("max_cycle_deg", &registration::PoseGraphOptions::max_cycle_deg)
      .def_readwrite("max_cycle_mm", &registration::PoseGraphOptions::max_cycle_mm);
  py::class_<registration::RegistrationOptions>(m, "RegistrationOptions",
                                                "Options of fringe.register (C++ defaults).")
      .def(OptionsInit<registration::RegistrationOptions>("RegistrationOptions"))
      .def_readwrite("use_markers", &registration::RegistrationOptions::use_markers)
      .def_readwrite("coarse_fallback", &registration::RegistrationOptions::coarse_fallback)
      .def_readwrite("adjust_markers", &registration::RegistrationOptions::adjust_markers)
      .def_readwrite("refine_icp", &registration::RegistrationOptions::refine_icp)
      .def_readwrite("min_extent_mm", &registration::RegistrationOptions::min_extent_mm)
      .def_readwrite("icp_threshold_factor",
                     &registration::RegistrationOptions::icp_threshold_factor)
      .def_readwrite("icp_min_start_threshold_mm",
                     &registration::RegistrationOptions::icp_min_start_threshold_mm)
      .def_readwrite("coarse_verify_min_overlap",
                     &registration::RegistrationOptions::coarse_verify_min_overlap)
      .def_readwrite("coarse_verify_tolerance_factor",
                     &registration::RegistrationOptions::coarse_verify_tolerance_factor)
      .def_readwrite("coarse_max_inconsistent",
                     &registration::RegistrationOptions::coarse_max_inconsistent)
      .def_readwrite("coarse_max_free_space",
                     &registration::RegistrationOptions::coarse_max_free_space)
      .def_readwrite("coarse_min_gap", &registration::RegistrationOptions::coarse_min_gap)
      .def_readwrite("coarse_same_pose_deg",
                     &registration::RegistrationOptions::coarse_same_pose_deg)
      .def_readwrite("coarse_same_pose_mm", &registration::RegistrationOptions::coarse_same_pose_mm)
      .def_readwrite("pose_graph", &registration::RegistrationOptions::pose_graph)
      .def_readwrite("matching", &registration::RegistrationOptions::matching)
      .def_readwrite("adjustment", &registration::RegistrationOptions::adjustment)
      .def_readwrite("coarse", &registration::RegistrationOptions::coarse)
      .def_readwrite("icp", &registration::RegistrationOptions::icp);

  py::class_<RegistrationResult, std::shared_ptr<RegistrationResult>>(m, "RegistrationResult",
                                                                      R"doc(
The views placed in one world frame (the first good view's sensor frame, mm): names,
world_from_sensor (list of 4x4, None for a view that was not placed), placed (list of bool),
paths (how each view was placed), summary (dict: the summary.json `fringe register` writes).
Pass it as `poses` to fringe.fuse.)doc")
      .def_property_readonly("names",
                             [](const RegistrationResult& r) {
                               std::vector<std::string> names;
                               for (const auto& v : r.views) names.push_back(v.name);
                               return names;
                             })
      .def_property_readonly("world_from_sensor",
                             [](const RegistrationResult& r) {
                               py::list out;
                               for (const auto& v : r.views) {
                                 if (v.placed()) {
                                   out.append(MatrixFromRigid(v.world_from_sensor));
                                 } else {
                                   out.append(py::none());
                                 }
                               }
                               return out;
                             })
      .def_property_readonly("placed",
                             [](const RegistrationResult& r) {
                               std::vector<bool> placed;
                               for (const auto& v : r.views) placed.push_back(v.placed());
                               return placed;
                             })
      .def_property_readonly("paths",
                             [](const RegistrationResult& r) {
                               std::vector<std::string> paths;
                               for (const auto& v : r.views) {
                                 paths.push_back(registration::ToString(v.path));
                               }
                               return paths;
                             })
      .def_property_readonly("ok", [](const RegistrationResult& r) { return r.summary.ok(); })
      .def_property_readonly(
          "summary", [](const RegistrationResult& r) { return FromJson(registration::ToJson(r)); })
      .def(
          "save_poses",
          [](const RegistrationResult& r, const fs::path& p) {
            std::vector<std::string> names;
            std::vector<Rigid3d> poses;
            for (const auto& v : r.views) {
              if (!v.placed()) continue;
              names.push_back(v.name);
              poses.push_back(v.world_from_sensor);
            }
            registration::WritePoses(p, names, poses);
          },
          py::arg("path"), "Writes the placed views' poses.json (as `fringe register`).")
      .def("brief_report", [](const RegistrationResult& r) { return r.summary.BriefReport(); })
      .def("__repr__", [](const RegistrationResult& r) {
        return "fringe.RegistrationResult(" + r.summary.BriefReport() + ")";
      });

  m.def(
      "register",
      [](const py::sequence& views, const py::object& names, const py::object& markers,
         const py::object& initial, double scale_to_mm, const py::object& options,
         const py::kwargs& kw) {
        const auto opts =
            MakeOptions<registration::RegistrationOptions>(options, kw, "RegistrationOptions");
        const std::vector<std::string> view_names = ViewNames(views, names);
        const size_t n = views.size();
        if (!markers.is_none() && py::len(markers) != n) {
          throw py::value_error("markers: expected one list (or None) per view");
        }
        if (!initial.is_none() && py::len(initial) != n) {
          throw py::value_error("initial: expected one pose (or None) per view");
        }
        const bool read_marker_files = markers.is_none();
        std::vector<registration::RegistrationView> in(n);
        for (size_t i = 0; i < n; ++i) {
          const py::object item = views[i];
          registration::RegistrationView& v = in[i];
          if (IsPath(item)) {
            std::string note;
            const fs::path path = item.cast<fs::path>();
            py::gil_scoped_release release;
            v = registration::ReadRegistrationView(path, scale_to_mm, read_marker_files, &note);
          } else if (py::isinstance<stereo::ViewReconstruction>(item)) {
            v.cloud = item.cast<const stereo::ViewReconstruction&>().cloud.Compact();
          } else if (py::isinstance<PointCloud>(item)) {
            v.cloud = item.cast<PointCloud>();
          } else {
            throw py::type_error("views[" + std::to_string(i) +
                                 "]: expected a PLY path, a ViewReconstruction or a PointCloud");
          }
          if (!IsPath(item) && scale_to_mm != 1.0) {
            for (auto& p : v.cloud.points) p *= scale_to_mm;
          }
          v.name = view_names[i];
          if (!markers.is_none() && !markers[py::int_(i)].is_none()) {
            v.markers = markers[py::int_(i)].cast<std::vector<registration::ViewMarker>>();
          }
          if (!initial.is_none() && !initial[py::int_(i)].is_none()) {
            v.initial_world_from_sensor =
                RigidFromPython(initial[py::int_(i)], "initial[" + std::to_string(i) + "]");
          }
        }
        auto result = std::make_shared<RegistrationResult>();
        py::gil_scoped_release release;
        *result = registration::RegisterViews(in, opts);
        return result;
      },
      py::arg("views"), py::arg("names") = py::none(), py::arg("markers") = py::none(),
      py::arg("initial") = py::none(), py::arg("scale_to_mm") = 1.0,
      py::arg("options") = py::none(),
      "Places view clouds (sensor frames) in one world frame, as `fringe register`: views are\n"
      "PLY paths (their VIEW.markers.json read unless `markers` is given), ViewReconstructions or\n"
      "PointClouds with normals; markers: per view a list of ViewMarker (fringe.detect_markers)\n"
      "or None; initial: per view a 4x4 world_from_sensor or None. Options: a\n"
      "RegistrationOptions and/or its fields as keyword arguments. Returns a RegistrationResult.");

  // ---- Fusion ----
  py::class_<fusion::FusionOptions>(m, "FusionOptions", "Options of fringe.fuse (C++ defaults).")
      .def(OptionsInit<fusion::FusionOptions>("FusionOptions"))
      .def_readwrite("spacing_factor", &fusion::FusionOptions::spacing_factor)
      .def_readwrite("seed_factor", &fusion::FusionOptions::seed_factor)
      .def_readwrite("border_seed_factor", &fusion::FusionOptions::border_seed_factor)
      .def_readwrite("border_seed_px", &fusion::FusionOptions::border_seed_px)
      .def_readwrite("registration_rms_mm", &fusion::FusionOptions::registration_rms_mm)
      .def_readwrite("registration_factor", &fusion::FusionOptions::registration_factor)
      .def_readwrite("max_normal_angle_deg", &fusion::FusionOptions::max_normal_angle_deg)
      .def_readwrite("lateral_sigma", &fusion::FusionOptions::lateral_sigma)
      .def_readwrite("max_disagreement", &fusion::FusionOptions::max_disagreement)
      .def_readwrite("max_iterations", &fusion::FusionOptions::max_iterations)
      .def_readwrite("convergence_mm", &fusion::FusionOptions::convergence_mm)
      .def_readwrite("max_moving_fraction", &fusion::FusionOptions::max_moving_fraction)
      .def_readwrite("modulation_half_dn", &fusion::FusionOptions::modulation_half_dn)
      .def_readwrite("residual_half_px", &fusion::FusionOptions::residual_half_px)
      .def_readwrite("min_cos_view", &fusion::FusionOptions::min_cos_view)
      .def_readwrite("border_ramp_px", &fusion::FusionOptions::border_ramp_px)
      .def_readwrite("border_trim_px", &fusion::FusionOptions::border_trim_px)
      .def_readwrite("one_view_cluster_border_px",
                     &fusion::FusionOptions::one_view_cluster_border_px)
      .def_readwrite("smooth_radius_px", &fusion::FusionOptions::smooth_radius_px)
      .def_readwrite("min_border_hole_px", &fusion::FusionOptions::min_border_hole_px)
      .def_readwrite("max_fit_error_px", &fusion::FusionOptions::max_fit_error_px)
      .def_readwrite("max_spacing_ratio", &fusion::FusionOptions::max_spacing_ratio);

  py::class_<fusion::FusionResult, std::shared_ptr<fusion::FusionResult>>(m, "FusionResult", R"doc(
The fused cloud (world frame, mm): cloud (PointCloud sharing the C++ storage), support (N,)
uint16 (views in each point's cluster), overlap (per view, (H*W,) uint8: 1 where the slot was in
an overlap), summary (dict: the "fusion" object `fringe fuse --json` prints).)doc")
      .def_property_readonly("cloud",
                             [](py::object self) {
                               auto owner = self.cast<std::shared_ptr<fusion::FusionResult>>();
                               return std::shared_ptr<PointCloud>(owner, &owner->fused);
                             })
      .def_property_readonly("support",
                             [](py::object self) {
                               auto& r = self.cast<fusion::FusionResult&>();
                               return ViewVector(
                                   r.support, {static_cast<py::ssize_t>(r.support.size())}, self);
                             })
      .def_property_readonly(
          "overlap",
          [](py::object self) {
            auto& r = self.cast<fusion::FusionResult&>();
            py::list out;
            for (auto& o : r.overlap) {
              out.append(ViewVector(o, {static_cast<py::ssize_t>(o.size())}, self));
            }
            return out;
          })
      .def_property_readonly("ok",
                             [](const fusion::FusionResult& r) { return r.summary.has_output(); })
      .def_property_readonly(
          "summary",
          [](const fusion::FusionResult& r) { return FromJson(fusion::ToJson(r.summary)); })
      .def("brief_report", [](const fusion::FusionResult& r) { return r.summary.BriefReport(); })
      .def("__repr__", [](const fusion::FusionResult& r) {
        return "fringe.FusionResult(" + r.summary.BriefReport() + ")";
      });

  m.def(
      "fuse",
      [](const py::sequence& views, const py::object& poses, const py::object& names,
         const py::object& options, const py::kwargs& kw) {
        const auto opts = MakeOptions<fusion::FusionOptions>(options, kw, "FusionOptions");
        const std::vector<std::string> view_names = ViewNames(views, names);
        const std::vector<Rigid3d> world_from_sensor = PosesFromPython(poses, views.size());
        std::vector<fusion::FusionView> in(views.size());
        for (size_t i = 0; i < views.size(); ++i) {
          const py::object item = views[i];
          if (IsPath(item)) {
            const fs::path path = item.cast<fs::path>();
            py::gil_scoped_release release;
            in[i].cloud = io::ReadOrganizedPly(path);
          } else if (py::isinstance<stereo::ViewReconstruction>(item)) {
            in[i].cloud = item.cast<const stereo::ViewReconstruction&>().cloud;
          } else {
            throw py::type_error("views[" + std::to_string(i) +
                                 "]: expected an organized PLY path or a ViewReconstruction");
          }
          in[i].name = view_names[i];
          in[i].world_from_sensor = world_from_sensor[i];
        }
        auto result = std::make_shared<fusion::FusionResult>();
        py::gil_scoped_release release;
        *result = fusion::FuseViews(in, opts);
        return result;
      },
      py::arg("views"), py::arg("poses"), py::arg("names") = py::none(),
      py::arg("options") = py::none(),
      "Fuses registered views into one single-layer cloud, as `fringe fuse`: views are organized\n"
      "PLY paths (as `fringe reconstruct` writes them) or ViewReconstructions; poses a\n"
      "RegistrationResult or a list of 4x4 world_from_sensor. Options: a FusionOptions and/or its\n"
      "fields as keyword arguments. Returns a FusionResult (a bad input is its summary's status).");

  // ---- Meshing ----
  py::enum_<fusion::MeshLibrary>(m, "MeshLibrary", "The Poisson implementation of fringe.mesh.")
      .value("open3d", fusion::MeshLibrary::kOpen3d)
      .value("cgal", fusion::MeshLibrary::kCgal);

  py::class_<fusion::MeshOptions>(m, "MeshOptions", "Options of fringe.mesh (C++ defaults).")
      .def(OptionsInit<fusion::MeshOptions>("MeshOptions"))
      .def_readwrite("library", &fusion::MeshOptions::library)
      .def_readwrite("poisson_depth", &fusion::MeshOptions::poisson_depth)
      .def_readwrite("cell_spacings", &fusion::MeshOptions::cell_spacings)
      .def_readwrite("resolution_mm", &fusion::MeshOptions::resolution_mm)
      .def_readwrite("max_auto_depth", &fusion::MeshOptions::max_auto_depth)
      .def_readwrite("watertight", &fusion::MeshOptions::watertight)
      .def_readwrite("trim_density_quantile", &fusion::MeshOptions::trim_density_quantile)
      .def_readwrite("trim_distance_factor", &fusion::MeshOptions::trim_distance_factor)
      .def_readwrite("max_surface_cells", &fusion::MeshOptions::max_surface_cells)
      .def_readwrite("project_to_points", &fusion::MeshOptions::project_to_points)
      .def_readwrite("project_neighbours", &fusion::MeshOptions::project_neighbours)
      .def_readwrite("max_project_flatness", &fusion::MeshOptions::max_project_flatness)
      .def_readwrite("max_project_spacings", &fusion::MeshOptions::max_project_spacings)
      .def_readwrite("max_triangles", &fusion::MeshOptions::max_triangles)
      .def_readwrite("threads", &fusion::MeshOptions::threads)
      .def_readwrite("poisson_pieces", &fusion::MeshOptions::poisson_pieces)
      .def_readwrite("min_cells_per_piece", &fusion::MeshOptions::min_cells_per_piece)
      .def_readwrite("piece_margin_cells", &fusion::MeshOptions::piece_margin_cells)
      .def_readwrite("max_seam_unmatched", &fusion::MeshOptions::max_seam_unmatched);

  py::class_<fusion::MeshResult, std::shared_ptr<fusion::MeshResult>>(m, "MeshResult", R"doc(
The surface: mesh (fringe.Mesh sharing the C++ storage), summary (dict: the "mesh" object
`fringe fuse --mesh --json` prints), ok.)doc")
      .def_property_readonly("mesh",
                             [](py::object self) {
                               auto owner = self.cast<std::shared_ptr<fusion::MeshResult>>();
                               return std::shared_ptr<TriangleMesh>(owner, &owner->mesh);
                             })
      .def_property_readonly("ok", [](const fusion::MeshResult& r) { return r.summary.ok(); })
      .def_property_readonly(
          "summary",
          [](const fusion::MeshResult& r) { return FromJson(fusion::ToJson(r.summary)); })
      .def("brief_report", [](const fusion::MeshResult& r) { return r.summary.BriefReport(); })
      .def("__repr__", [](const fusion::MeshResult& r) {
        return "fringe.MeshResult(" + r.summary.BriefReport() + ")";
      });

  m.def(
      "mesh",
      [](const py::object& cloud, const py::object& options, const py::kwargs& kw) {
        const auto opts = MakeOptions<fusion::MeshOptions>(options, kw, "MeshOptions");
        const PointCloud* input = nullptr;
        if (py::isinstance<fusion::FusionResult>(cloud)) {
          input = &cloud.cast<const fusion::FusionResult&>().fused;
        } else if (py::isinstance<PointCloud>(cloud)) {
          input = &cloud.cast<const PointCloud&>();
        } else {
          throw py::type_error("cloud: expected a PointCloud with normals or a FusionResult");
        }
        auto result = std::make_shared<fusion::MeshResult>();
        py::gil_scoped_release release;
        *result = fusion::MeshPoisson(*input, opts);
        return result;
      },
      py::arg("cloud"), py::arg("options") = py::none(),
      "Screened Poisson surface of a cloud with normals (e.g. fringe.fuse's), trimmed and\n"
      "optionally decimated, as `fringe fuse --mesh`. Options: a MeshOptions and/or its fields as\n"
      "keyword arguments. Returns a MeshResult (save with result.mesh.save(path)).");
}

}  // namespace fringe::python
