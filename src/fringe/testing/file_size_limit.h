// Test support: a full disk simulated without root. Lowers the soft RLIMIT_FSIZE of the process
// so that no file can grow past `bytes` (a write beyond it fails with EFBIG, the way a full disk
// fails with ENOSPC: the same stream state and the same partial write) and ignores SIGXFSZ,
// which would otherwise end the process; both are restored at destruction. Process-wide: hold it
// only around the code under test (gtest runs one test at a time; terminals and pipes are not
// limited, only regular files).
#pragma once

#include <signal.h>
#include <sys/resource.h>

#include <algorithm>
#include <cstdint>

namespace fringe::test {

class FileSizeLimit {
 public:
  explicit FileSizeLimit(std::uint64_t bytes) {
    ::getrlimit(RLIMIT_FSIZE, &old_);
    struct rlimit limit = old_;
    limit.rlim_cur = old_.rlim_max == RLIM_INFINITY
                         ? static_cast<rlim_t>(bytes)
                         : std::min<rlim_t>(static_cast<rlim_t>(bytes), old_.rlim_max);
    old_handler_ = ::signal(SIGXFSZ, SIG_IGN);
    ::setrlimit(RLIMIT_FSIZE, &limit);
  }
  ~FileSizeLimit() {
    ::setrlimit(RLIMIT_FSIZE, &old_);
    ::signal(SIGXFSZ, old_handler_);
  }
  FileSizeLimit(const FileSizeLimit&) = delete;
  FileSizeLimit& operator=(const FileSizeLimit&) = delete;

 private:
  struct rlimit old_ {};
  void (*old_handler_)(int) = SIG_DFL;
};

}  // namespace fringe::test
