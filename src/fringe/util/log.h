// Minimal logging and progress display on stderr. Libraries stay quiet unless a caller raises the
// verbosity; the CLI sets it from --quiet / --verbose.
#pragma once

#include <chrono>
#include <string>

namespace fringe::util {

enum class Verbosity { kQuiet = 0, kNormal = 1, kVerbose = 2 };

void SetVerbosity(Verbosity v);
Verbosity GetVerbosity();

void LogInfo(const std::string& message);     // shown at kNormal and above
void LogVerbose(const std::string& message);  // shown at kVerbose
void LogWarning(const std::string& message);  // always shown unless kQuiet

// Progress of a long step ("reconstruct: view 3 of 8, 4.1 s elapsed, ~6.2 s left"), on one
// terminal line that is overwritten; the estimate of the time left assumes the remaining steps
// take as long as the done ones did on average. Thread safe; prints nothing at kQuiet or when
// stderr is not a terminal (except the final line).
class Progress {
 public:
  Progress(std::string label, int total);
  ~Progress();
  void Advance(int steps = 1);
  // Changes the label mid-way (e.g. the stage of a multi-stage run); shown at the next update.
  void SetLabel(std::string label);

 private:
  std::string label_;
  int total_;
  int done_ = 0;
  bool tty_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace fringe::util
