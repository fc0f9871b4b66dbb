// Minimal logging and progress display on stderr. Libraries stay quiet unless a caller raises the
// verbosity; the CLI sets it from --quiet / --verbose.
#pragma once

#include <string>

namespace fringe::util {

enum class Verbosity { kQuiet = 0, kNormal = 1, kVerbose = 2 };

void SetVerbosity(Verbosity v);
Verbosity GetVerbosity();

void LogInfo(const std::string& message);     // shown at kNormal and above
void LogVerbose(const std::string& message);  // shown at kVerbose
void LogWarning(const std::string& message);  // always shown unless kQuiet

// Progress of a long step ("render view 3/8"), on one terminal line that is overwritten.
// Thread safe; prints nothing at kQuiet or when stderr is not a terminal (except at the end).
class Progress {
 public:
  Progress(std::string label, int total);
  ~Progress();
  void Advance(int steps = 1);

 private:
  std::string label_;
  int total_;
  int done_ = 0;
  bool tty_;
};

}  // namespace fringe::util
