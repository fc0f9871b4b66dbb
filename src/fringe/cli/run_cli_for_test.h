// Test support: runs `fringe ARGS...` in-process and captures what it prints (one copy for every
// CLI test file).
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "fringe/cli/cli.h"

namespace fringe::cli {

inline int RunCli(std::vector<std::string> args, std::string* out = nullptr,
                  std::string* err = nullptr) {
  args.insert(args.begin(), "fringe");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const int rc = Main(static_cast<int>(argv.size()), argv.data());
  const std::string o = testing::internal::GetCapturedStdout();
  const std::string e = testing::internal::GetCapturedStderr();
  if (out) *out = o;
  if (err) *err = e;
  return rc;
}

}  // namespace fringe::cli
