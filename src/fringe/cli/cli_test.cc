#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include "fringe/cli/cli.h"
#include "fringe/io/ply.h"
#include "fringe/util/files.h"
#include "fringe_test.h"

namespace fringe::cli {
namespace {

int RunCli(std::vector<std::string> args, std::string* out = nullptr, std::string* err = nullptr) {
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

TEST(Cli, HelpListsSubcommandsAndVersion) {
  std::string out;
  EXPECT_EQ(RunCli({"--help"}, &out), 0);
  EXPECT_NE(out.find("info"), std::string::npos);
  EXPECT_NE(out.find("demo"), std::string::npos);
  EXPECT_EQ(RunCli({"--version"}, &out), 0);
  EXPECT_NE(out.find("fringe "), std::string::npos);
}

TEST(Cli, UsageErrorsExitWith2) {
  std::string err;
  EXPECT_EQ(RunCli({"frobnicate"}, nullptr, &err), 2);
  EXPECT_NE(err.find("usage error"), std::string::npos) << err;
  EXPECT_EQ(RunCli({"info", "--no-such-flag", "x"}), 2);
  EXPECT_EQ(RunCli({}), 2);
}

TEST(Cli, InfoOnPlyAndTruncatedPly) {
  test::TempDir dir;
  PointCloud c;
  for (int i = 0; i < 1000; ++i) c.points.emplace_back(i, 2 * i, 3 * i);
  io::WritePly(dir / "c.ply", c);
  std::string out, err;
  EXPECT_EQ(RunCli({"info", (dir / "c.ply").string()}, &out), 0);
  EXPECT_NE(out.find("points: 1000"), std::string::npos) << out;
  const std::string data = util::ReadTextFile(dir / "c.ply");
  {
    std::ofstream f(dir / "t.ply", std::ios::binary);
    f << data.substr(0, data.size() / 2);
  }
  EXPECT_EQ(RunCli({"info", (dir / "t.ply").string()}, &out, &err), 1);
  EXPECT_NE(err.find("t.ply: truncated"), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << "one-line error: " << err;
}

}  // namespace
}  // namespace fringe::cli
