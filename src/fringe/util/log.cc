#include "fringe/util/log.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <mutex>

namespace fringe::util {
namespace {
std::atomic<int> g_verbosity{static_cast<int>(Verbosity::kQuiet)};
std::mutex g_mutex;
}  // namespace

void SetVerbosity(Verbosity v) { g_verbosity = static_cast<int>(v); }
Verbosity GetVerbosity() { return static_cast<Verbosity>(g_verbosity.load()); }

void LogInfo(const std::string& message) {
  if (g_verbosity < static_cast<int>(Verbosity::kNormal)) return;
  std::lock_guard<std::mutex> lock(g_mutex);
  std::fprintf(stderr, "%s\n", message.c_str());
}

void LogVerbose(const std::string& message) {
  if (g_verbosity < static_cast<int>(Verbosity::kVerbose)) return;
  std::lock_guard<std::mutex> lock(g_mutex);
  std::fprintf(stderr, "%s\n", message.c_str());
}

void LogWarning(const std::string& message) {
  if (g_verbosity < static_cast<int>(Verbosity::kNormal)) return;
  std::lock_guard<std::mutex> lock(g_mutex);
  std::fprintf(stderr, "warning: %s\n", message.c_str());
}

Progress::Progress(std::string label, int total)
    : label_(std::move(label)), total_(total), tty_(::isatty(STDERR_FILENO) != 0) {}

Progress::~Progress() {
  if (g_verbosity < static_cast<int>(Verbosity::kNormal)) return;
  std::lock_guard<std::mutex> lock(g_mutex);
  std::fprintf(stderr, "%s%s: %d/%d done\n", tty_ ? "\r" : "", label_.c_str(), done_, total_);
}

void Progress::Advance(int steps) {
  std::lock_guard<std::mutex> lock(g_mutex);
  done_ += steps;
  if (!tty_ || g_verbosity < static_cast<int>(Verbosity::kNormal)) return;
  std::fprintf(stderr, "\r%s: %d/%d", label_.c_str(), done_, total_);
  std::fflush(stderr);
}

}  // namespace fringe::util
