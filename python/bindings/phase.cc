// Pattern schemes, pattern images and decoding.
#include <optional>

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.h"
#include "convert.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/scheme_presets.h"
#include "fringe/phase/stack_io.h"
#include "fringe/util/error.h"

namespace fringe::python {

void BindPhase(py::module_& m) {
  py::class_<phase::PatternScheme>(m, "Scheme", R"doc(
A fringe pattern scheme: what the projector shows and in which order (docs/formats.md,
"Pattern scheme manifest"). Make one with Scheme.preset(name) or Scheme.load(path).)doc")
      .def_static(
          "preset",
          [](const std::string& name, std::optional<int> width, std::optional<int> height,
             bool horizontal, std::optional<std::vector<double>> counts, std::optional<int> steps,
             std::optional<int> markers, std::optional<std::string> image_names) {
            phase::SchemeParameters p;
            p.projector_width = width.value_or(0);
            p.projector_height = height.value_or(0);
            p.horizontal = horizontal;
            if (counts) p.counts = *counts;
            p.steps = steps.value_or(0);
            p.markers = markers.value_or(-1);
            if (image_names) p.image_names = *image_names;
            return phase::MakePresetScheme(name, p);
          },
          py::arg("name"), py::arg("projector_width") = py::none(),
          py::arg("projector_height") = py::none(), py::arg("horizontal") = false,
          py::arg("counts") = py::none(), py::arg("steps") = py::none(),
          py::arg("markers") = py::none(), py::arg("image_names") = py::none(),
          "A preset scheme (see Scheme.presets(): fringe's own and other tools' codecs) for a\n"
          "projector of the given size (default: the preset's, 1280 x 800), with the parameters\n"
          "of `fringe patterns` (counts, steps, markers, image_names; docs/formats.md).")
      .def_static("presets", &phase::AllPresetNames,
                  "Every preset name: fringe's own (gray+4 stands for gray+N), then other tools' "
                  "codecs (slstudio-*, opencv-*, slmaster-*).")
      .def_static(
          "load", [](const std::filesystem::path& p) { return phase::ReadScheme(p); },
          py::arg("path"), "Reads a scheme manifest (JSON).")
      .def_static(
          "from_dict",
          [](const py::dict& d) {
            const std::string text = py::str(py::module_::import("json").attr("dumps")(d));
            return phase::SchemeFromJson(nlohmann::json::parse(text), "Scheme.from_dict");
          },
          py::arg("manifest"), "A scheme from its manifest as a dict.")
      .def(
          "save",
          [](const phase::PatternScheme& s, const std::filesystem::path& p) {
            phase::WriteScheme(p, s);
          },
          py::arg("path"), "Writes the scheme manifest (JSON) atomically.")
      .def(
          "to_dict", [](const phase::PatternScheme& s) { return FromJson(phase::SchemeToJson(s)); },
          "The scheme manifest as a dict.")
      .def_readonly("name", &phase::PatternScheme::name)
      .def_readonly("projector_width", &phase::PatternScheme::projector_width)
      .def_readonly("projector_height", &phase::PatternScheme::projector_height)
      .def_property_readonly(
          "direction",
          [](const phase::PatternScheme& s) { return phase::DirectionName(s.direction); })
      .def_readwrite("gamma_precompensation", &phase::PatternScheme::gamma_precompensation)
      .def_property_readonly("periods_px",
                             [](const phase::PatternScheme& s) {
                               std::vector<double> p;
                               for (const auto& set : s.phase_sets) p.push_back(set.period_px);
                               return p;
                             })
      .def_property_readonly("num_images", &phase::PatternScheme::NumImages)
      .def_property_readonly("image_names", &phase::PatternScheme::ImageNames)
      .def("check", &phase::PatternScheme::Check)
      .def("__repr__", [](const phase::PatternScheme& s) {
        return util::StrCat("fringe.Scheme('", s.name, "', ", s.NumImages(), " images, ",
                            s.projector_width, "x", s.projector_height, ")");
      });

  m.def(
      "patterns",
      [](const phase::PatternScheme& scheme, std::optional<double> precompensate_gamma) {
        // The scheme states what is projected (gamma_precompensation); an explicit gamma is for
        // a scheme that does not say it yet.
        const double gamma = precompensate_gamma.value_or(scheme.gamma_precompensation);
        std::vector<cv::Mat> images;
        {
          py::gil_scoped_release release;
          images = phase::GeneratePatterns(scheme, gamma);
        }
        return ArraysFromMats(images);
      },
      py::arg("scheme"), py::arg("precompensate_gamma") = py::none(),
      "The projector images (uint8, projector_height x projector_width) in the scheme's order,\n"
      "pre-compensated for precompensate_gamma (default: the scheme's gamma_precompensation).");

  py::class_<phase::DecodeOptions>(m, "DecodeOptions", "Options of fringe.decode (C++ defaults).")
      .def(OptionsInit<phase::DecodeOptions>("DecodeOptions"))
      .def_readwrite("noise_sigma_dn", &phase::DecodeOptions::noise_sigma_dn)
      .def_readwrite("order_error_probability", &phase::DecodeOptions::order_error_probability)
      .def_readwrite("min_modulation_dn", &phase::DecodeOptions::min_modulation_dn)
      .def_readwrite("full_scale_dn", &phase::DecodeOptions::full_scale_dn)
      .def_readwrite("saturation_dn", &phase::DecodeOptions::saturation_dn)
      .def_readwrite("min_background_fraction", &phase::DecodeOptions::min_background_fraction)
      .def_readwrite("min_modulation_ratio", &phase::DecodeOptions::min_modulation_ratio)
      .def_readwrite("max_order_residual", &phase::DecodeOptions::max_order_residual)
      .def_readwrite("spatial_check_fraction", &phase::DecodeOptions::spatial_check_fraction)
      .def_readwrite("repair_orders", &phase::DecodeOptions::repair_orders)
      .def_readwrite("whole_stack", &phase::DecodeOptions::whole_stack)
      .def_readwrite("projector_gamma", &phase::DecodeOptions::projector_gamma)
      .def("check", &phase::DecodeOptions::Check);

  // Results own their images; the arrays share the buffers (no copy).
  py::class_<phase::DecodeResult, std::shared_ptr<phase::DecodeResult>>(m, "DecodeResult", R"doc(
One camera's decoded stack: absolute_phase (float32, projector pixels, NaN invalid),
wrapped_phase (float32, radians), modulation and background (float32, DN), mask (bool) and
summary (dict, as `fringe decode` writes summary.json).)doc")
      .def_property_readonly(
          "absolute_phase",
          [](const phase::DecodeResult& r) { return ArrayFromMat(r.absolute_phase); })
      .def_property_readonly(
          "wrapped_phase",
          [](const phase::DecodeResult& r) { return ArrayFromMat(r.wrapped_phase); })
      .def_property_readonly(
          "modulation", [](const phase::DecodeResult& r) { return ArrayFromMat(r.modulation); })
      .def_property_readonly(
          "background", [](const phase::DecodeResult& r) { return ArrayFromMat(r.background); })
      .def_property_readonly("mask",
                             [](const phase::DecodeResult& r) {
                               // 0/255 bytes viewed as bool would read 255 as True but compare
                               // oddly; convert once.
                               return ArrayFromMat(r.mask).attr("astype")("bool");
                             })
      .def_property_readonly(
          "summary",
          [](const phase::DecodeResult& r) { return FromJson(phase::ToJson(r.summary)); })
      .def("brief_report", [](const phase::DecodeResult& r) { return r.summary.BriefReport(); })
      .def("__repr__", [](const phase::DecodeResult& r) {
        return "fringe.DecodeResult(" + r.summary.BriefReport() + ")";
      });

  m.def(
      "decode",
      [](const py::object& images, const phase::PatternScheme& scheme, const py::object& options,
         const py::kwargs& kwargs) {
        const auto opts = MakeOptions<phase::DecodeOptions>(options, kwargs, "DecodeOptions");
        ImageStack stack = ImagesFromPython(images, "images");
        auto result = std::make_shared<phase::DecodeResult>();
        py::gil_scoped_release release;
        *result = phase::Decode(scheme, stack.mats, opts);
        return result;
      },
      py::arg("images"), py::arg("scheme"), py::arg("options") = py::none(),
      "Decodes one camera's stack (uint8/uint16 images in the scheme's order) to absolute phase.\n"
      "Options: a DecodeOptions and/or its fields as keyword arguments.");
  m.def(
      "read_stack",
      [](const std::filesystem::path& dir, const phase::PatternScheme& scheme) {
        std::vector<cv::Mat> images;
        {
          py::gil_scoped_release release;
          images = phase::ReadStack(dir, scheme);
        }
        return ArraysFromMats(images);
      },
      py::arg("dir"), py::arg("scheme"),
      "Reads the scheme's images from a folder (8- or 16-bit grey), checked as `fringe decode` "
      "does.");
}

}  // namespace fringe::python
