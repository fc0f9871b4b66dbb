// Locating ../shared/data for tests and benchmarks. Tests that need it skip with a reason when it
// is absent, unless FRINGE_REQUIRE_SHARED_DATA=1 (CI), where they fail instead.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace fringe::util {

// The shared data folder: $FRINGE_SHARED_DATA if set, else <source>/../shared/data where
// <source> is $FRINGE_SOURCE_DIR (set by CTest) or the current directory. Empty if absent.
std::optional<std::filesystem::path> SharedDataDir();

// True when FRINGE_REQUIRE_SHARED_DATA is set (missing data must fail, not skip).
bool SharedDataRequired();

}  // namespace fringe::util
