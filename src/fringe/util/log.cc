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

namespace {
double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace

Progress::Progress(std::string label, int total)
    : label_(std::move(label)),
      total_(total),
      tty_(::isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()) {}

Progress::~Progress() {
  if (g_verbosity < static_cast<int>(Verbosity::kNormal)) return;
  std::lock_guard<std::mutex> lock(g_mutex);
  // \x1b[K clears what a longer previous line left on the terminal.
  std::fprintf(stderr, "%s%s: %d of %d done in %.1f s\n", tty_ ? "\r\x1b[K" : "", label_.c_str(),
               done_, total_, SecondsSince(start_));
}

void Progress::SetLabel(std::string label) {
  std::lock_guard<std::mutex> lock(g_mutex);
  label_ = std::move(label);
}

void Progress::Advance(int steps) {
  std::lock_guard<std::mutex> lock(g_mutex);
  done_ += steps;
  if (!tty_ || g_verbosity < static_cast<int>(Verbosity::kNormal)) return;
  const double elapsed = SecondsSince(start_);
  if (done_ > 0 && done_ < total_) {
    const double left = elapsed / done_ * (total_ - done_);
    std::fprintf(stderr, "\r\x1b[K%s: %d of %d, %.1f s elapsed, ~%.1f s left", label_.c_str(),
                 done_, total_, elapsed, left);
  } else {
    std::fprintf(stderr, "\r\x1b[K%s: %d of %d, %.1f s elapsed", label_.c_str(), done_, total_,
                 elapsed);
  }
  std::fflush(stderr);
}

}  // namespace fringe::util
