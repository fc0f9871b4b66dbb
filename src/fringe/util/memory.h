// Process memory figures for summaries and benchmarks (Linux /proc; 0 where unavailable).
#pragma once

namespace fringe::util {

// Peak resident set size of this process so far (VmHWM), GiB.
double PeakMemoryGiB();
// Current resident set size (VmRSS), GiB.
double CurrentMemoryGiB();

}  // namespace fringe::util
