// Human-readable description of what a file or folder holds (`fringe info`): a PLY's elements,
// properties, bounds and grid; a rig's cameras and baseline; a scan folder's manifest, views,
// images and truth (checked by ScanFolder::Open); another folder's image sub-folders.
#pragma once

#include <filesystem>
#include <string>

namespace fringe::scan {

// Throws fringe::Error when the path is missing or cannot be read.
std::string DescribePath(const std::filesystem::path& path);

}  // namespace fringe::scan
