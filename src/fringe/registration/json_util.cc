#include "fringe/registration/json_util.h"

#include <cmath>
#include <system_error>

#include "fringe/io/calibration_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::registration::internal {

using nlohmann::json;
using util::StrCat;

json ReadJsonBounded(const std::filesystem::path& path) {
  util::RequireFile(path);
  std::error_code ec;
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  if (ec) throw Error(StrCat(path.string(), ": cannot read its size: ", ec.message()));
  if (bytes > kMaxJsonBytes) {
    throw Error(StrCat(path.string(), ": ", bytes, " bytes, more than the ", kMaxJsonBytes,
                       " accepted for a JSON file"));
  }
  return io::ReadJson(path);
}

void CheckFormat(const json& j, const std::string& format, const std::string& context) {
  if (!j.is_object()) throw Error(StrCat(context, ": expected a JSON object"));
  if (j.contains("format") && (!j["format"].is_string() || j["format"] != format)) {
    throw Error(StrCat(context, ": format is ", j["format"].dump(), ", expected \"", format, "\""));
  }
  if (j.contains("version") && (!j["version"].is_number_integer() || j["version"] != 1)) {
    throw Error(StrCat(context, ": version ", j["version"].dump(), " is not supported (1)"));
  }
}

double FiniteNumber(const json& j, const char* key, const std::string& context) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) {
    throw Error(StrCat(context, ".", key, ": expected a number"));
  }
  const double v = j[key].get<double>();
  if (!std::isfinite(v)) throw Error(StrCat(context, ".", key, ": not finite"));
  return v;
}

namespace {
template <int N>
Eigen::Matrix<double, N, 1> VectorN(const json& j, const char* key, const std::string& context) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_array() || j[key].size() != N) {
    throw Error(StrCat(context, ".", key, ": expected ", N, " numbers"));
  }
  Eigen::Matrix<double, N, 1> v;
  for (int i = 0; i < N; ++i) {
    if (!j[key][i].is_number()) throw Error(StrCat(context, ".", key, ": expected numbers"));
    v[i] = j[key][i].get<double>();
  }
  if (!v.allFinite()) throw Error(StrCat(context, ".", key, ": not finite"));
  return v;
}
}  // namespace

Eigen::Vector3d Vector3(const json& j, const char* key, const std::string& context) {
  return VectorN<3>(j, key, context);
}
Eigen::Vector2d Vector2(const json& j, const char* key, const std::string& context) {
  return VectorN<2>(j, key, context);
}

Eigen::Vector3d UnitVector3(const json& j, const char* key, const std::string& context) {
  const Eigen::Vector3d v = Vector3(j, key, context);
  if (std::abs(v.norm() - 1) > 1e-3) {
    throw Error(StrCat(context, ".", key, ": not a unit vector (norm ", v.norm(), ")"));
  }
  return v.normalized();
}

const json& BoundedArray(const json& j, const char* key, size_t max_size,
                         const std::string& context) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_array()) {
    throw Error(StrCat(context, ".", key, ": expected an array"));
  }
  if (j[key].size() > max_size) {
    throw Error(StrCat(context, ".", key, ": ", j[key].size(), " entries, more than the ", max_size,
                       " accepted"));
  }
  return j[key];
}

json ToJson(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }
json ToJson(const Eigen::Vector2d& v) { return json::array({v.x(), v.y()}); }

}  // namespace fringe::registration::internal
