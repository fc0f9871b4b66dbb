// The virtual scanner: scenes rendered to fringe and board images with exact ground truth.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.h"
#include "convert.h"
#include "fringe/io/calibration_io.h"
#include "fringe/sim/projector_board.h"
#include "fringe/sim/scan.h"

namespace fringe::python {

namespace {

py::object Truth(const sim::CameraTruth& t) {
  if (t.depth.empty()) return py::none();
  py::dict d;
  d["depth"] = ArrayFromMat(t.depth);
  d["points"] = ArrayFromMat(t.points);
  d["normals"] = ArrayFromMat(t.normals);
  d["projector"] = ArrayFromMat(t.projector);
  d["valid"] = ArrayFromMat(t.valid).attr("astype")("bool");
  d["object_id"] = ArrayFromMat(t.object_id);
  return std::move(d);
}

py::dict Board(const sim::BoardImage& b) {
  py::dict d;
  d["image"] = ArrayFromMat(b.image);
  d["cam_from_board"] = MatrixFromRigid(b.cam_from_board);
  py::array_t<double> centres({static_cast<py::ssize_t>(b.centres_px.size()), py::ssize_t{2}});
  for (size_t i = 0; i < b.centres_px.size(); ++i) {
    centres.mutable_at(i, 0) = b.centres_px[i].x();
    centres.mutable_at(i, 1) = b.centres_px[i].y();
  }
  d["centres_px"] = centres;
  py::array_t<bool> visible(static_cast<py::ssize_t>(b.visible.size()));
  for (size_t i = 0; i < b.visible.size(); ++i) visible.mutable_at(i) = b.visible[i] != 0;
  d["visible"] = visible;
  return d;
}

using ViewPtr = std::shared_ptr<sim::ViewImages>;

}  // namespace

void BindSim(py::module_& m) {
  py::enum_<TargetType>(m, "TargetType")
      .value("rings", TargetType::kConcentricRings)
      .value("circles", TargetType::kCircleGrid)
      .value("asymmetric_circles", TargetType::kAsymmetricCircleGrid)
      .value("chessboard", TargetType::kChessboard);
  py::class_<CalibrationTarget>(m, "Target",
                                "A calibration board (docs/formats.md, \"Calibration target\").")
      .def(OptionsInit<CalibrationTarget>("Target"))
      .def_static(
          "load", [](const std::filesystem::path& p) { return io::ReadTarget(p); }, py::arg("path"))
      .def(
          "save",
          [](const CalibrationTarget& t, const std::filesystem::path& p) {
            io::WriteJson(p, io::TargetToJson(t));
          },
          py::arg("path"))
      .def("to_dict", [](const CalibrationTarget& t) { return FromJson(io::TargetToJson(t)); })
      .def_readwrite("type", &CalibrationTarget::type)
      .def_readwrite("rows", &CalibrationTarget::rows)
      .def_readwrite("cols", &CalibrationTarget::cols)
      .def_readwrite("spacing_mm", &CalibrationTarget::spacing_mm)
      .def_readwrite("outer_radius_mm", &CalibrationTarget::outer_radius_mm)
      .def_readwrite("inner_radius_mm", &CalibrationTarget::inner_radius_mm)
      .def_readwrite("dot_radius_mm", &CalibrationTarget::dot_radius_mm)
      .def_readwrite("margin_mm", &CalibrationTarget::margin_mm)
      .def_readwrite("distinct_features", &CalibrationTarget::distinct_features)
      .def("check", &CalibrationTarget::Check);

  py::class_<sim::SensorOptions>(m, "SensorOptions")
      .def(OptionsInit<sim::SensorOptions>("SensorOptions"))
      .def_readwrite("supersampling", &sim::SensorOptions::supersampling)
      .def_readwrite("exposure", &sim::SensorOptions::exposure)
      .def_readwrite("bit_depth", &sim::SensorOptions::bit_depth)
      .def_readwrite("noise", &sim::SensorOptions::noise)
      .def_readwrite("read_noise_dn", &sim::SensorOptions::read_noise_dn)
      .def_readwrite("shot_noise", &sim::SensorOptions::shot_noise)
      .def_readwrite("electrons_per_dn", &sim::SensorOptions::electrons_per_dn)
      .def_readwrite("defocus_sigma_px", &sim::SensorOptions::defocus_sigma_px)
      .def_readwrite("float_output", &sim::SensorOptions::float_output)
      .def_readwrite("seed", &sim::SensorOptions::seed);
  py::class_<sim::ProjectorOptions>(m, "ProjectorOptions")
      .def(OptionsInit<sim::ProjectorOptions>("ProjectorOptions"))
      .def_readwrite("gamma", &sim::ProjectorOptions::gamma)
      .def_readwrite("black_level", &sim::ProjectorOptions::black_level)
      .def_readwrite("brightness", &sim::ProjectorOptions::brightness)
      .def_readwrite("ambient", &sim::ProjectorOptions::ambient)
      .def_readwrite("defocus_sigma_px", &sim::ProjectorOptions::defocus_sigma_px)
      .def_readwrite("pixelated", &sim::ProjectorOptions::pixelated);
  py::class_<sim::RenderOptions>(m, "RenderOptions")
      .def(OptionsInit<sim::RenderOptions>("RenderOptions"))
      .def_readwrite("sensor", &sim::RenderOptions::sensor)
      .def_readwrite("projector", &sim::RenderOptions::projector)
      .def_readwrite("truth", &sim::RenderOptions::truth)
      .def_readwrite("shadow_offset_mm", &sim::RenderOptions::shadow_offset_mm)
      .def_readwrite("marker_visibility_tolerance_mm",
                     &sim::RenderOptions::marker_visibility_tolerance_mm);
  py::class_<sim::BoardRenderOptions>(m, "BoardRenderOptions")
      .def(OptionsInit<sim::BoardRenderOptions>("BoardRenderOptions"))
      .def_readwrite("sensor", &sim::BoardRenderOptions::sensor)
      .def_readwrite("edge_supersampling", &sim::BoardRenderOptions::edge_supersampling)
      .def_readwrite("white_albedo", &sim::BoardRenderOptions::white_albedo)
      .def_readwrite("black_albedo", &sim::BoardRenderOptions::black_albedo)
      .def_readwrite("background_albedo", &sim::BoardRenderOptions::background_albedo)
      .def_readwrite("illumination", &sim::BoardRenderOptions::illumination);
  py::class_<sim::OrbitOptions>(m, "OrbitOptions")
      .def(OptionsInit<sim::OrbitOptions>("OrbitOptions"))
      .def_readwrite("views", &sim::OrbitOptions::views)
      .def_readwrite("turntable", &sim::OrbitOptions::turntable)
      .def_readwrite("elevation_deg", &sim::OrbitOptions::elevation_deg)
      .def_readwrite("elevation_jitter_deg", &sim::OrbitOptions::elevation_jitter_deg)
      .def_readwrite("azimuth_start_deg", &sim::OrbitOptions::azimuth_start_deg)
      .def_readwrite("azimuth_jitter_deg", &sim::OrbitOptions::azimuth_jitter_deg)
      .def_readwrite("roll_jitter_deg", &sim::OrbitOptions::roll_jitter_deg)
      .def_readwrite("standoff_jitter_mm", &sim::OrbitOptions::standoff_jitter_mm)
      .def_readwrite("seed", &sim::OrbitOptions::seed);
  py::class_<sim::BoardPoseOptions>(m, "BoardPoseOptions")
      .def(OptionsInit<sim::BoardPoseOptions>("BoardPoseOptions"))
      .def_readwrite("count", &sim::BoardPoseOptions::count)
      .def_readwrite("min_distance_mm", &sim::BoardPoseOptions::min_distance_mm)
      .def_readwrite("max_distance_mm", &sim::BoardPoseOptions::max_distance_mm)
      .def_readwrite("max_tilt_deg", &sim::BoardPoseOptions::max_tilt_deg)
      .def_readwrite("max_roll_deg", &sim::BoardPoseOptions::max_roll_deg)
      .def_readwrite("min_visible_fraction", &sim::BoardPoseOptions::min_visible_fraction)
      .def_readwrite("both_cameras", &sim::BoardPoseOptions::both_cameras)
      .def_readwrite("seed", &sim::BoardPoseOptions::seed);
  py::class_<sim::ScanOptions>(m, "ScanOptions",
                               "Options of fringe.Simulator / fringe.simulate_scan (C++ defaults).")
      .def(OptionsInit<sim::ScanOptions>("ScanOptions"))
      .def_readwrite("scene", &sim::ScanOptions::scene)
      .def_readwrite("views", &sim::ScanOptions::views)
      .def_readwrite("seed", &sim::ScanOptions::seed)
      .def_readwrite("scheme", &sim::ScanOptions::scheme)
      .def_readwrite("calibration_images", &sim::ScanOptions::calibration_images)
      .def_readwrite("target", &sim::ScanOptions::target)
      .def_readwrite("truth_maps", &sim::ScanOptions::truth_maps)
      .def_readwrite("render", &sim::ScanOptions::render)
      .def_readwrite("board", &sim::ScanOptions::board)
      .def_readwrite("orbit", &sim::ScanOptions::orbit)
      .def_readwrite("board_poses", &sim::ScanOptions::board_poses);

  py::class_<sim::ViewImages, ViewPtr>(m, "SimulatedView", R"doc(
One rendered view: left / right image lists (uint8 or uint16, the scheme's order),
left_truth / right_truth (dicts of depth, points, normals, projector, valid, object_id arrays in
that camera's frame; None without truth), world_from_sensor (4x4), markers (list of dicts).)doc")
      .def_property_readonly("left",
                             [](const sim::ViewImages& v) { return ArraysFromMats(v.left.images); })
      .def_property_readonly(
          "right", [](const sim::ViewImages& v) { return ArraysFromMats(v.right.images); })
      .def_property_readonly("left_truth",
                             [](const sim::ViewImages& v) { return Truth(v.left.truth); })
      .def_property_readonly("right_truth",
                             [](const sim::ViewImages& v) { return Truth(v.right.truth); })
      .def_property_readonly(
          "world_from_sensor",
          [](const sim::ViewImages& v) { return MatrixFromRigid(v.world_from_sensor); })
      .def_property_readonly("markers", [](const sim::ViewImages& v) {
        py::list out;
        for (const auto& mk : v.markers) {
          py::dict d;
          d["id"] = mk.id;
          d["centre_in_sensor"] = std::vector<double>{
              mk.centre_in_sensor.x(), mk.centre_in_sensor.y(), mk.centre_in_sensor.z()};
          d["left_px"] = std::vector<double>{mk.left_px.x(), mk.left_px.y()};
          out.append(d);
        }
        return out;
      });

  py::class_<sim::ScanSimulator>(m, "Simulator", R"doc(
The virtual scanner in memory (the same images `fringe simulate` writes): a scene seen by the rig
(default the reference rig) from ScanOptions' orbit of views, and calibration board poses.)doc")
      .def(py::init([](const py::object& rig, const py::object& options, const py::kwargs& kw) {
             const auto opts = MakeOptions<sim::ScanOptions>(options, kw, "ScanOptions");
             const StereoRig r = rig.is_none() ? StereoRig::Reference() : rig.cast<StereoRig>();
             py::gil_scoped_release release;
             return std::make_unique<sim::ScanSimulator>(r, opts);
           }),
           py::arg("rig") = py::none(), py::arg("options") = py::none())
      .def_property_readonly("rig", &sim::ScanSimulator::rig)
      .def_property_readonly("scheme", &sim::ScanSimulator::scheme,
                             "The scheme, gamma_precompensation set.")
      .def_property_readonly(
          "patterns", [](const sim::ScanSimulator& s) { return ArraysFromMats(s.patterns()); })
      .def_property_readonly("views", [](const sim::ScanSimulator& s) { return s.options().views; })
      .def_property_readonly(
          "calibration_images",
          [](const sim::ScanSimulator& s) { return s.options().calibration_images; })
      .def_property_readonly(
          "view_poses",
          [](const sim::ScanSimulator& s) {
            py::list out;
            for (const auto& p : s.view_poses()) out.append(MatrixFromRigid(p));
            return out;
          },
          "world_from_sensor of every view (4x4).")
      .def(
          "render_view",
          [](const sim::ScanSimulator& s, int view) {
            if (view < 0 || view >= s.options().views) {
              throw py::index_error("render_view: view " + std::to_string(view) + " not in [0, " +
                                    std::to_string(s.options().views) + ")");
            }
            auto out = std::make_shared<sim::ViewImages>();
            py::gil_scoped_release release;
            *out = s.RenderView(view);
            return out;
          },
          py::arg("view"), "Renders fringe view `view` (both cameras, all patterns, truth).")
      .def(
          "render_board",
          [](const sim::ScanSimulator& s, int index) {
            if (index < 0 || index >= s.options().calibration_images) {
              throw py::index_error("render_board: index " + std::to_string(index) +
                                    " not in [0, " +
                                    std::to_string(s.options().calibration_images) + ")");
            }
            sim::StereoBoardImages b;
            {
              py::gil_scoped_release release;
              b = s.RenderBoard(index);
            }
            return py::make_tuple(Board(b.left), Board(b.right));
          },
          py::arg("index"),
          "Renders board pose `index`: (left, right) dicts of image, cam_from_board, centres_px, "
          "visible.");

  m.def(
      "simulate",
      [](const py::object& rig, const py::object& options, const py::kwargs& kw) {
        auto opts = MakeOptions<sim::ScanOptions>(options, kw, "ScanOptions");
        opts.calibration_images = 0;  // views only: simulate_scan writes board images
        const StereoRig r = rig.is_none() ? StereoRig::Reference() : rig.cast<StereoRig>();
        std::vector<std::shared_ptr<sim::ViewImages>> views;
        {
          py::gil_scoped_release release;
          const sim::ScanSimulator simulator(r, opts);
          for (int v = 0; v < opts.views; ++v) {
            views.push_back(std::make_shared<sim::ViewImages>(simulator.RenderView(v)));
          }
        }
        return views;
      },
      py::arg("rig") = py::none(), py::arg("options") = py::none(),
      R"doc(Simulates a scene in memory: images and truth of every view.

Returns a list of SimulatedView (both cameras' images in the scheme's order, truth maps,
world_from_sensor, markers), the same images `fringe simulate` writes for the same rig (default
the reference rig) and ScanOptions (keyword fields: scene="demo", views=6, seed=1, ...).
Calibration board images are not rendered (see Simulator.render_board, simulate_scan).)doc");

  m.def(
      "simulate_scan",
      [](const std::filesystem::path& out, const py::object& rig, const py::object& options,
         const py::kwargs& kw) {
        const auto opts = MakeOptions<sim::ScanOptions>(options, kw, "ScanOptions");
        const StereoRig r = rig.is_none() ? StereoRig::Reference() : rig.cast<StereoRig>();
        sim::ScanSummary s;
        {
          py::gil_scoped_release release;
          s = sim::SimulateScan(r, opts, out);
        }
        return FromJson(ToJson(s));
      },
      py::arg("out"), py::arg("rig") = py::none(), py::arg("options") = py::none(),
      "Writes a scan folder (docs/scan-folder.md) as `fringe simulate` does; returns its summary.");
  m.def(
      "simulate_projector_calibration",
      [](const std::filesystem::path& out, const StereoRig& rig, const CalibrationTarget& target,
         int poses, uint64_t seed, bool two_cameras, int supersampling, const std::string& preset) {
        sim::ProjectorCalibrationFolderOptions o;
        o.poses.count = poses;
        o.poses.seed = seed;
        o.two_cameras = two_cameras;
        o.fringes.supersampling = supersampling;
        o.preset = preset;
        std::vector<Rigid3d> left_from_board;
        {
          py::gil_scoped_release release;
          left_from_board = sim::WriteProjectorCalibrationFolder(rig, target, out, o);
        }
        py::list poses_out;
        for (const Rigid3d& t : left_from_board) poses_out.append(MatrixFromRigid(t));
        return poses_out;
      },
      py::arg("out"), py::arg("rig"), py::arg("target"), py::arg("poses") = 5, py::arg("seed") = 1,
      py::arg("two_cameras") = false, py::arg("supersampling") = 1,
      py::arg("preset") = "heterodyne-4x3",
      "Writes a projector calibration folder (docs/scan-folder.md: per board pose the plain board\n"
      "image and fringe stacks of both directions with manifests, for one camera or two) and\n"
      "out/target.json, rendered with the rig (the truth); returns the poses left_from_board\n"
      "(4x4 matrices).");
  // Defined here because ScaledRig belongs to the simulator (quick scaled-down scans).
  py::object rig_class = m.attr("Rig");
  rig_class.attr("scaled") = py::cpp_function(&sim::ScaledRig, py::name("scaled"),
                                              py::is_method(rig_class), py::arg("scale"),
                                              "The rig with every device's resolution and focal "
                                              "lengths scaled (e.g. 0.25 for quick scans).");
  m.def("scene_names", &sim::SceneNames, "Names accepted by ScanOptions.scene.");
}

}  // namespace fringe::python
