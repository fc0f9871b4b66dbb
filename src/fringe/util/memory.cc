#include "fringe/util/memory.h"

#include <unistd.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#if defined(__SANITIZE_ADDRESS__)
#define FRINGE_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define FRINGE_ADDRESS_SANITIZER 1
#endif
#endif

namespace fringe::util {
namespace {

// A "Key:   123 kB" line of /proc/self/status in GiB; 0 when the file or key is missing
// (non-Linux systems), which summaries print as "not measured".
double StatusFieldGiB(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::string prefix = std::string(key) + ":";
  while (std::getline(in, line)) {
    if (line.compare(0, prefix.size(), prefix) != 0) continue;
    std::istringstream fields(line.substr(prefix.size()));
    double kib = 0;
    fields >> kib;
    return kib / (1024.0 * 1024.0);
  }
  return 0;
}

}  // namespace

double PeakMemoryGiB() { return StatusFieldGiB("VmHWM"); }
double CurrentMemoryGiB() { return StatusFieldGiB("VmRSS"); }

double PhysicalMemoryGiB() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return 0;
  return double(pages) * double(page) / (1024.0 * 1024.0 * 1024.0);
}

void ReleaseFreeMemory() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

void UseTransparentHugePages(char** argv) {
#if defined(__linux__) && !defined(FRINGE_ADDRESS_SANITIZER)
  // Set (to 0 by the user, or to 1 by this function before it re-executes): nothing to do, so
  // the re-executed program (and any program it starts) does not re-execute again.
  if (std::getenv("FRINGE_HUGE_PAGES") != nullptr) return;
  if (setenv("FRINGE_HUGE_PAGES", "1", 1) != 0) return;
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (tunables != nullptr && std::strstr(tunables, "glibc.malloc.hugetlb") != nullptr) return;
  std::string value = "glibc.malloc.hugetlb=1";
  if (tunables != nullptr && *tunables != '\0') value = std::string(tunables) + ":" + value;
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // Only reached when the re-execution failed: go on without huge pages.
#else
  (void)argv;
#endif
}

}  // namespace fringe::util
