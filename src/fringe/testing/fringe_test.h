// Helpers for the GoogleTest tests (TempDir is defined in fringe_test_main, main.cc): include it
// from tests only; it needs gtest, which fringe_testing itself does not link.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>

#include "fringe/testing/data.h"
#include "fringe/util/error.h"

namespace fringe::test {

// A fresh empty folder under the system temp dir, removed at destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

// The message of the fringe::Error that f throws, "" when it throws none (other exceptions pass).
inline std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace fringe::test

// Declares `const std::filesystem::path var` = ../shared/data/<sub>; skips the test with a reason
// when absent, or fails when FRINGE_REQUIRE_SHARED_DATA=1.
#define FRINGE_SHARED_DATA_OR_SKIP(var, sub)                                                    \
  const auto var##_root = ::fringe::util::SharedDataDir();                                      \
  if (!var##_root || !std::filesystem::exists(*var##_root / (sub))) {                           \
    if (::fringe::util::SharedDataRequired()) {                                                 \
      FAIL() << "shared data " << (sub) << " is missing and FRINGE_REQUIRE_SHARED_DATA is set"; \
    }                                                                                           \
    GTEST_SKIP() << "shared data " << (sub) << " not found (../shared/data absent)";            \
  }                                                                                             \
  const std::filesystem::path var = *var##_root / (sub)
