// The extension module fringe._fringe; python/fringe/__init__.py re-exports it as `fringe`.
#include <pybind11/pybind11.h>

#include "bindings.h"
#include "fringe/util/error.h"

namespace py = pybind11;

PYBIND11_MODULE(_fringe, m) {
  m.doc() = "fringe: fringe-projection 3D measurement (C++ library bindings)";
  // fringe::Error (bad input, bad options, unreadable or unwritable files) carries a complete
  // message naming the file or field; Python sees it as fringe.Error.
  py::register_exception<fringe::Error>(m, "Error", PyExc_RuntimeError);
  fringe::python::BindGeometryIo(m);
  fringe::python::BindPhase(m);
  fringe::python::BindCalib(m);
  fringe::python::BindStereo(m);
  fringe::python::BindEval(m);
  fringe::python::BindSim(m);
  fringe::python::BindMultiView(m);
  fringe::python::BindPipeline(m);
}
