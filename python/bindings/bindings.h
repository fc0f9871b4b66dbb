// One Bind* function per binding file; module.cc calls them in layer order.
#pragma once

#include <pybind11/pybind11.h>

#include <string>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/triangle_mesh.h"

namespace fringe::python {

void BindGeometryIo(pybind11::module_& m);
void BindPhase(pybind11::module_& m);
void BindCalib(pybind11::module_& m);
void BindStereo(pybind11::module_& m);
void BindEval(pybind11::module_& m);
void BindSim(pybind11::module_& m);
void BindMultiView(pybind11::module_& m);
void BindPipeline(pybind11::module_& m);

// A PointCloud from numpy arrays (geometry_io.cc); None for absent attributes.
PointCloud CloudFromArrays(const pybind11::handle& points, const pybind11::handle& normals,
                           const pybind11::handle& colors, const pybind11::handle& intensity,
                           const pybind11::handle& quality);

// A TriangleMesh from a fringe.Mesh, a PlyFile with faces, a mesh file path (.ply/.stl/.obj)
// or a (vertices, triangles) tuple (geometry_io.cc); `what` names the argument in errors.
TriangleMesh MeshFromPython(const pybind11::handle& mesh, const std::string& what);

}  // namespace fringe::python
