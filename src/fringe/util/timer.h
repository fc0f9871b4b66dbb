// Wall-clock and process CPU timing for summaries and benchmarks.
#pragma once

#include <time.h>

#include <chrono>

namespace fringe::util {

class Timer {
 public:
  Timer() : start_(Clock::now()) {}
  void Restart() { start_ = Clock::now(); }
  double ElapsedSeconds() const {
    return std::chrono::duration<double>(Clock::now() - start_).count();
  }
  double ElapsedMs() const { return 1e3 * ElapsedSeconds(); }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point start_;
};

// CPU time of the whole process (all threads) since Restart(): beside a wall time it shows how
// much of a stage ran in parallel, and it stays comparable on a machine shared with other jobs.
class CpuTimer {
 public:
  CpuTimer() : start_(Now()) {}
  void Restart() { start_ = Now(); }
  double ElapsedSeconds() const { return Now() - start_; }

 private:
  static double Now() {
    timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
  }
  double start_;
};

}  // namespace fringe::util
