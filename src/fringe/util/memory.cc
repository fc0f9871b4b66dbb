#include "fringe/util/memory.h"

#include <fstream>
#include <sstream>
#include <string>

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

}  // namespace fringe::util
