// Timing helpers shared by the benchmark programs: wall time as the median of repeated runs,
// process CPU time (all threads), which stays comparable on a machine shared with other jobs.
#pragma once

#include <time.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <tbb/parallel_for.h>

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

// FNV-1a over bytes: two builds whose digests of the same outputs agree computed identical bits.
struct Digest {
  uint64_t value = 14695981039346656037ull;
  void Add(const void* data, size_t bytes) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (size_t k = 0; k < bytes; ++k) value = (value ^ b[k]) * 1099511628211ull;
  }
  std::string Hex() const {
    char text[17];
    std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(value));
    return text;
  }
};

// This machine's memory bandwidth, GB/s: bytes copied per second by memcpy over buffers far
// larger than any cache (256 MiB), split over all threads; the best of `repeats` copies.
inline double CopyBandwidthGbPerS(int repeats = 5) {
  const size_t bytes = size_t{256} << 20;
  std::vector<char> from(bytes, 1), to(bytes, 2);
  const size_t chunk = size_t{4} << 20;
  double best_s = 1e30;
  for (int i = 0; i < repeats; ++i) {
    util::Timer timer;
    tbb::parallel_for(size_t{0}, bytes / chunk,
                      [&](size_t c) { std::memcpy(&to[c * chunk], &from[c * chunk], chunk); });
    best_s = std::min(best_s, timer.ElapsedSeconds());
  }
  return bytes / best_s * 1e-9;
}

}  // namespace fringe::bench
