// File-system helpers. Outputs are written under a temporary name next to the target and renamed
// at the end, so a failure never leaves a half-written file (or folder) behind.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

namespace fringe::util {

namespace fs = std::filesystem;

// Calls write(tmp_path) with a temporary path in the same directory (same extension, so
// extension-driven writers such as cv::imwrite work), then renames it to `path`. On any
// exception the temporary is removed and the exception propagates. Throws fringe::Error when
// the directory does not exist or is not writable.
void WriteAtomically(const fs::path& path, const std::function<void(const fs::path& tmp)>& write);

// Same for a whole output folder: write(tmp_dir) fills a fresh temporary folder which then
// replaces `dir` (an existing `dir` is removed only after the new one is complete).
void WriteFolderAtomically(const fs::path& dir,
                           const std::function<void(const fs::path& tmp_dir)>& write);

// Throws fringe::Error("<path>: <what>: no such file") when `path` is not a regular file.
void RequireFile(const fs::path& path, const std::string& what = "file");
// Throws fringe::Error when `path` is not a directory.
void RequireDirectory(const fs::path& path, const std::string& what = "folder");

// Reads a whole text file; throws fringe::Error naming the file on failure.
std::string ReadTextFile(const fs::path& path);

// Environment variable as a flag: set to something other than "", "0", "false".
bool EnvFlag(const char* name);

}  // namespace fringe::util
