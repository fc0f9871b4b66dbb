// Internal helpers of the registration files (markers, poses): bounded JSON reading and checked
// field access, so every reader names the file and field the same way.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace fringe::registration::internal {

// Files larger than this are refused before reading (a marker or pose file of a real scan is a
// few hundred kB at most).
constexpr std::uintmax_t kMaxJsonBytes = 64u << 20;
// Upper bounds on list lengths in these files.
constexpr size_t kMaxMarkers = 100000;
constexpr size_t kMaxViews = 100000;

// Reads `path` after checking its size against kMaxJsonBytes; errors name the file.
nlohmann::json ReadJsonBounded(const std::filesystem::path& path);

// Checks that j["format"] equals `format` and j["version"] is 1 when present.
void CheckFormat(const nlohmann::json& j, const std::string& format, const std::string& context);

// j[key] as a finite number / finite 3- or 2-vector; throws naming context.key.
double FiniteNumber(const nlohmann::json& j, const char* key, const std::string& context);
Eigen::Vector3d Vector3(const nlohmann::json& j, const char* key, const std::string& context);
Eigen::Vector2d Vector2(const nlohmann::json& j, const char* key, const std::string& context);
// A finite vector whose norm is within 1e-3 of 1, returned normalised.
Eigen::Vector3d UnitVector3(const nlohmann::json& j, const char* key, const std::string& context);
// j[key] as an array with at most `max_size` entries.
const nlohmann::json& BoundedArray(const nlohmann::json& j, const char* key, size_t max_size,
                                   const std::string& context);

nlohmann::json ToJson(const Eigen::Vector3d& v);
nlohmann::json ToJson(const Eigen::Vector2d& v);

}  // namespace fringe::registration::internal
