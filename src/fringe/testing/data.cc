#include "fringe/testing/data.h"

#include <cstdlib>

#include "fringe/util/files.h"

namespace fringe::util {

std::optional<std::filesystem::path> SharedDataDir() {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (const char* env = std::getenv("FRINGE_SHARED_DATA")) {
    if (fs::is_directory(env, ec)) return fs::path(env);
    return std::nullopt;
  }
  fs::path source = fs::current_path();
  if (const char* env = std::getenv("FRINGE_SOURCE_DIR")) source = env;
  const fs::path candidate = source / ".." / "shared" / "data";
  if (fs::is_directory(candidate, ec)) return fs::weakly_canonical(candidate);
  return std::nullopt;
}

bool SharedDataRequired() { return EnvFlag("FRINGE_REQUIRE_SHARED_DATA"); }

}  // namespace fringe::util
