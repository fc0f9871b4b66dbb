#include "fringe/geometry/triangle_mesh.h"

#include <Eigen/Geometry>
#include <limits>

#include "fringe/util/error.h"

namespace fringe {

void TriangleMesh::Append(const TriangleMesh& other) {
  const bool was_empty = vertices.empty();
  const bool keep_normals = (was_empty || has_normals()) && other.has_normals();
  const bool keep_colors = (was_empty || has_colors()) && other.has_colors();
  const int32_t offset = static_cast<int32_t>(vertices.size());
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  triangles.reserve(triangles.size() + other.triangles.size());
  for (const Triangle& t : other.triangles) {
    triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  }
  if (keep_normals) {
    normals.insert(normals.end(), other.normals.begin(), other.normals.end());
  } else {
    normals.clear();
  }
  if (keep_colors) {
    colors.insert(colors.end(), other.colors.begin(), other.colors.end());
  } else {
    colors.clear();
  }
}

void TriangleMesh::Transform(const Rigid3d& b_from_a) {
  for (auto& v : vertices) v = b_from_a * v;
  for (auto& n : normals) n = b_from_a.rotation() * n;
}

Eigen::Vector3d TriangleMesh::TriangleNormal(size_t i) const {
  const Triangle& t = triangles[i];
  const Eigen::Vector3d n =
      (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]);
  const double len = n.norm();
  return len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
}

void TriangleMesh::ComputeVertexNormals() {
  normals.assign(vertices.size(), Eigen::Vector3d::Zero());
  for (const Triangle& t : triangles) {
    // The unnormalized cross product is twice the area times the unit normal: area weighting.
    const Eigen::Vector3d n =
        (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]);
    for (int32_t k : t) normals[k] += n;
  }
  for (auto& n : normals) {
    const double len = n.norm();
    n = len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
  }
}

void TriangleMesh::Bounds(Eigen::Vector3d* min, Eigen::Vector3d* max) const {
  if (vertices.empty()) {
    *min = *max = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
    return;
  }
  *min = *max = vertices.front();
  for (const auto& v : vertices) {
    *min = min->cwiseMin(v);
    *max = max->cwiseMax(v);
  }
}

void TriangleMesh::Check(const std::string& context) const {
  for (size_t i = 0; i < vertices.size(); ++i) {
    if (!vertices[i].allFinite()) {
      throw Error(util::StrCat(context, ": vertex ", i, " is not finite"));
    }
  }
  const int32_t n = static_cast<int32_t>(vertices.size());
  for (size_t i = 0; i < triangles.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (triangles[i][k] < 0 || triangles[i][k] >= n) {
        throw Error(util::StrCat(context, ": triangle ", i, " has vertex index ", triangles[i][k],
                                 " outside [0, ", n, ")"));
      }
    }
  }
  if (!normals.empty() && normals.size() != vertices.size()) {
    throw Error(
        util::StrCat(context, ": ", normals.size(), " normals for ", vertices.size(), " vertices"));
  }
  if (!colors.empty() && colors.size() != vertices.size()) {
    throw Error(
        util::StrCat(context, ": ", colors.size(), " colours for ", vertices.size(), " vertices"));
  }
}

}  // namespace fringe
