// GoogleTest main shared by every test binary: re-seeds the process-wide generator before each
// test (from the test's full name), so every test is reproducible alone or in any order.
#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "fringe/util/random.h"

namespace {

class ReseedListener : public ::testing::EmptyTestEventListener {
  void OnTestStart(const ::testing::TestInfo& info) override {
    const std::string name = std::string(info.test_suite_name()) + "." + info.name();
    fringe::util::SetGlobalSeed(std::hash<std::string>{}(name));
  }
};

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::UnitTest::GetInstance()->listeners().Append(new ReseedListener);
  return RUN_ALL_TESTS();
}

// TempDir lives here so that every test binary has it without another library.
#include <unistd.h>

#include <atomic>

#include "fringe/testing/fringe_test.h"

namespace fringe::test {

TempDir::TempDir() {
  static std::atomic<int> counter{0};
  path_ = std::filesystem::temp_directory_path() /
          ("fringe_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

}  // namespace fringe::test
