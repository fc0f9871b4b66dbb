#include "fringe/util/files.h"

#include <gtest/gtest.h>

#include <fstream>

#include "fringe/util/error.h"
#include "fringe_test.h"

namespace fringe::util {
namespace {

TEST(WriteAtomically, WritesAndLeavesNoTemporary) {
  test::TempDir dir;
  const fs::path out = dir / "a.txt";
  WriteAtomically(out, [](const fs::path& tmp) { std::ofstream(tmp) << "hello"; });
  EXPECT_EQ(ReadTextFile(out), "hello");
  int n = 0;
  for (auto& e : fs::directory_iterator(dir.path())) n += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(n, 1);
}

TEST(WriteAtomically, FailureLeavesNothing) {
  test::TempDir dir;
  const fs::path out = dir / "a.txt";
  EXPECT_THROW(WriteAtomically(out,
                               [](const fs::path& tmp) {
                                 std::ofstream(tmp) << "half";
                                 throw Error("boom");
                               }),
               Error);
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(WriteAtomically, MissingFolderNamesThePath) {
  test::TempDir dir;
  const fs::path out = dir / "no" / "such" / "a.txt";
  try {
    WriteAtomically(out, [](const fs::path&) {});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("a.txt"), std::string::npos) << e.what();
  }
}

TEST(WriteFolderAtomically, ReplacesExistingFolderOnlyOnSuccess) {
  test::TempDir dir;
  const fs::path out = dir / "scan";
  WriteFolderAtomically(out, [](const fs::path& tmp) { std::ofstream(tmp / "x") << "1"; });
  EXPECT_EQ(ReadTextFile(out / "x"), "1");
  EXPECT_THROW(WriteFolderAtomically(out,
                                     [](const fs::path& tmp) {
                                       std::ofstream(tmp / "x") << "2";
                                       throw Error("boom");
                                     }),
               Error);
  EXPECT_EQ(ReadTextFile(out / "x"), "1");
  WriteFolderAtomically(out, [](const fs::path& tmp) { std::ofstream(tmp / "y") << "3"; });
  EXPECT_FALSE(fs::exists(out / "x"));
  EXPECT_EQ(ReadTextFile(out / "y"), "3");
}

TEST(RequireFile, NamesFileAndProblem) {
  try {
    RequireFile("/nonexistent/file.png", "image");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/file.png: image: no such file");
  }
}

TEST(CheckOption, MessageNamesFieldValueAndConstraint) {
  try {
    CheckOption(false, "IcpOptions", "max_iterations", -3, "must be > 0");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "IcpOptions.max_iterations = -3: must be > 0");
  }
  EXPECT_NO_THROW(CheckOption(true, "A", "b", 1, "c"));
}

}  // namespace
}  // namespace fringe::util
