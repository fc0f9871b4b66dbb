// Human-readable description of what a file or folder holds (`fringe info`): a PLY's elements,
// properties, bounds and grid; a rig's cameras and baseline; a scan folder's views and images.
#pragma once

#include <filesystem>
#include <string>

namespace fringe::io {

// Throws fringe::Error when the path is missing or cannot be read.
std::string DescribePath(const std::filesystem::path& path);

}  // namespace fringe::io
