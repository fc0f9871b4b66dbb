// Shared by the libFuzzer targets: readers that take a path get the input through a file in a
// per-process temporary folder (the same code path users hit). Every target treats
// fringe::Error as the expected outcome of bad input; anything else (a crash, a sanitizer
// report, another exception type) is a finding.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace fringe::fuzz {

// Writes the input to <tmp>/fringe-fuzz-<pid>/<name> and returns the path.
inline std::filesystem::path InputFile(const uint8_t* data, size_t size, const std::string& name) {
  static const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("fringe-fuzz-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path path = dir / name;
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace fringe::fuzz
