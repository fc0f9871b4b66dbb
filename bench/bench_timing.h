// Timing helpers shared by the benchmark programs: wall time as the median of repeated runs,
// process CPU time (all threads), which stays comparable on a machine shared with other jobs.
#pragma once

#include <time.h>

#include <algorithm>
#include <vector>

#include "fringe/util/timer.h"

namespace fringe::bench {

// Median of the values (upper median for an even count); `v` must not be empty.
inline double Median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Process CPU time in ms, summed over all threads.
inline double CpuMs() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

// Process CPU time per run of f (all threads) after one warm-up run: the work, independent of
// other load on the machine.
template <typename F>
double CpuMsPerRun(int repeats, F&& f) {
  f();
  const double c0 = CpuMs();
  for (int i = 0; i < repeats; ++i) f();
  return (CpuMs() - c0) / repeats;
}

// Median wall time in ms of `repeats` runs of f after one warm-up run.
template <typename F>
double TimeMs(int repeats, F&& f) {
  std::vector<double> t;
  f();  // warm-up
  for (int i = 0; i < repeats; ++i) {
    util::Timer timer;
    f();
    t.push_back(timer.ElapsedMs());
  }
  return Median(t);
}

}  // namespace fringe::bench
