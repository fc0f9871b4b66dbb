// Process memory figures for summaries and benchmarks (Linux /proc; 0 where unavailable).
#pragma once

namespace fringe::util {

// Peak resident set size of this process so far (VmHWM), GiB.
double PeakMemoryGiB();
// Current resident set size (VmRSS), GiB.
double CurrentMemoryGiB();
// Physical memory of the machine (sysconf _SC_PHYS_PAGES x _SC_PAGE_SIZE), GiB; 0 when unknown.
double PhysicalMemoryGiB();
// Hands the heap's free pages back to the system (glibc malloc_trim; nothing elsewhere), so that
// CurrentMemoryGiB measures what is held after large buffers were freed.
void ReleaseFreeMemory();

// Large buffers on transparent huge pages. On a machine whose THP mode is "madvise" (Debian's
// default, and this project's machines), every 4 KiB page a buffer touches for the first time is
// a page fault, and on a virtual machine a page fault is expensive: 13 us here, i.e. 3.4 ms per
// MB, against 0.08 ms per MB with 2 MiB pages (scripts: docs/benchmarks.md, "Page faults"). A
// view touches ~150 MB of fresh memory (phase maps, rectified maps, the organized cloud and its
// normals), so without huge pages it spends more time in the kernel than computing.
// glibc's malloc madvises its heap and its mmap'd chunks MADV_HUGEPAGE when the tunable
// glibc.malloc.hugetlb=1 is set, which glibc reads only at start-up: this function, called first
// in main, re-executes the program (/proc/self/exe, same arguments) with that tunable added to
// GLIBC_TUNABLES, once. It returns (does nothing) when the tunable is already set, when
// FRINGE_HUGE_PAGES is set (=0 turns this off; the re-executed program finds it =1), when the
// binary is built with AddressSanitizer (its own allocator), on non-Linux systems, or when the
// re-execution fails. Results do not depend on it.
void UseTransparentHugePages(char** argv);

}  // namespace fringe::util
