#include "fringe/util/files.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>  // renameat2, RENAME_EXCHANGE (glibc >= 2.28)
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>

#include "fringe/util/error.h"

namespace fringe::util {
namespace {

// ---------------------------------------------------------------------------------------------
// Temporaries removed on SIGINT / SIGTERM / SIGHUP. The handler may run at any point, so it only
// reads fixed slots (no allocation, no locks) and removes them with raw system calls.

constexpr int kMaxTemporaries = 64;
constexpr size_t kMaxTemporaryPath = 4096;

struct TemporarySlot {
  std::atomic<bool> used{false};
  char path[kMaxTemporaryPath];
};

TemporarySlot g_temporaries[kMaxTemporaries];
std::mutex g_temporaries_mutex;

// Removes `name` (relative to dirfd) and, for a folder, everything below it, using only
// async-signal-safe calls (getdents64 instead of opendir, which allocates).
void RemoveTreeAt(int dirfd, const char* name, int depth) {
  if (::unlinkat(dirfd, name, 0) == 0 || errno == ENOENT) return;
  if (depth > 16) return;  // fringe's temporaries are shallow; never chase a deep tree here
  const int fd = ::openat(dirfd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return;
  char buf[2048];
  // Removing entries while listing may skip some: list again until a pass finds nothing.
  for (int pass = 0; pass < 64; ++pass) {
    bool removed_any = false;
    ::lseek(fd, 0, SEEK_SET);
    for (;;) {
      const ssize_t n = ::getdents64(fd, buf, sizeof(buf));
      if (n <= 0) break;
      for (ssize_t off = 0; off < n;) {
        const auto* e = reinterpret_cast<const struct dirent64*>(buf + off);
        off += e->d_reclen;
        if (std::strcmp(e->d_name, ".") == 0 || std::strcmp(e->d_name, "..") == 0) continue;
        RemoveTreeAt(fd, e->d_name, depth + 1);
        removed_any = true;
      }
    }
    if (!removed_any) break;
  }
  ::close(fd);
  ::unlinkat(dirfd, name, AT_REMOVEDIR);
}

extern "C" void RemoveTemporariesOnSignal(int sig) {
  for (auto& slot : g_temporaries) {
    if (slot.used.load(std::memory_order_acquire)) RemoveTreeAt(AT_FDCWD, slot.path, 0);
  }
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

// Installs the handler for signals whose disposition is still the default (a host program's own
// handler, e.g. a debugger's or Python's, is left alone).
void InstallSignalCleanup() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
      struct sigaction old {};
      if (::sigaction(sig, nullptr, &old) != 0 || old.sa_handler != SIG_DFL) continue;
      struct sigaction sa {};
      sa.sa_handler = RemoveTemporariesOnSignal;
      sigemptyset(&sa.sa_mask);
      ::sigaction(sig, &sa, nullptr);
    }
  });
}

// Registers a temporary path for removal on a signal while alive.
class TemporaryRegistration {
 public:
  explicit TemporaryRegistration(const fs::path& path) {
    std::error_code ec;
    const std::string p = fs::absolute(path, ec).string();
    if (ec || p.size() >= kMaxTemporaryPath) return;  // not registered: only signal cleanup lost
    InstallSignalCleanup();
    std::lock_guard<std::mutex> lock(g_temporaries_mutex);
    for (int i = 0; i < kMaxTemporaries; ++i) {
      if (!g_temporaries[i].used.load(std::memory_order_relaxed)) {
        std::memcpy(g_temporaries[i].path, p.c_str(), p.size() + 1);
        g_temporaries[i].used.store(true, std::memory_order_release);
        slot_ = i;
        return;
      }
    }
  }
  ~TemporaryRegistration() {
    if (slot_ < 0) return;
    std::lock_guard<std::mutex> lock(g_temporaries_mutex);
    g_temporaries[slot_].used.store(false, std::memory_order_release);
  }
  TemporaryRegistration(const TemporaryRegistration&) = delete;
  TemporaryRegistration& operator=(const TemporaryRegistration&) = delete;

 private:
  int slot_ = -1;
};

// ---------------------------------------------------------------------------------------------

fs::path ParentOf(const fs::path& path) {
  return path.parent_path().empty() ? fs::path(".") : path.parent_path();
}

// ".<stem>.tmp<pid>_<n><ext>": hidden, unique per process and call, keeps the extension.
std::string TemporaryPrefix(const fs::path& path) {
  return StrCat(".", path.stem().string(), ".tmp");
}

fs::path TemporarySibling(const fs::path& path) {
  static std::atomic<int> counter{0};
  return ParentOf(path) /
         StrCat(TemporaryPrefix(path), ::getpid(), "_", counter++, path.extension().string());
}

// Removes temporaries of `path` left by processes that no longer run (killed with SIGKILL, power
// loss): names ".<stem>.tmp<pid>_..." whose pid does not exist. Only exact matches of fringe's
// own naming are touched.
std::vector<fs::path> StaleTemporaries(const fs::path& path) {
  std::vector<fs::path> stale;
  const std::string prefix = TemporaryPrefix(path);
  std::error_code ec;
  fs::directory_iterator it(ParentOf(path), ec), end;
  for (; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    size_t i = prefix.size(), j = i;
    while (j < name.size() && std::isdigit(static_cast<unsigned char>(name[j]))) ++j;
    if (j == i || j - i > 9 || j >= name.size() || name[j] != '_') continue;
    const pid_t pid = static_cast<pid_t>(std::stol(name.substr(i, j - i)));
    if (pid == ::getpid() || pid <= 0) continue;
    if (::kill(pid, 0) == 0 || errno != ESRCH) continue;  // alive (or not ours to judge)
    stale.push_back(it->path());
  }
  return stale;
}

void RemoveStaleTemporaries(const fs::path& path) {
  for (const fs::path& p : StaleTemporaries(path)) {
    std::error_code ignored;
    fs::remove_all(p, ignored);
  }
}

// The newest temporary folder a dead run left for `dir` that holds what it kept for reuse
// (kResumeFolder), moved to `tmp` with everything else in it removed; false when there is none.
bool TakeOverStaleTemporary(const fs::path& dir, const fs::path& tmp) {
  std::optional<fs::path> newest;
  fs::file_time_type newest_time{};
  for (const fs::path& p : StaleTemporaries(dir)) {
    std::error_code ec;
    if (fs::is_symlink(p, ec) || !fs::is_directory(p / kResumeFolder, ec)) continue;
    const fs::file_time_type t = fs::last_write_time(p / kResumeFolder, ec);
    if (ec) continue;
    if (!newest || t > newest_time) {
      newest = p;
      newest_time = t;
    }
  }
  if (!newest) return false;
  std::error_code ec;
  fs::rename(*newest, tmp, ec);
  if (ec) return false;
  for (const auto& e : fs::directory_iterator(tmp, ec)) {
    if (e.path().filename() == kResumeFolder) continue;
    std::error_code ignored;
    fs::remove_all(e.path(), ignored);
  }
  return true;
}

void RequireWritableParent(const fs::path& path) {
  const fs::path parent = ParentOf(path);
  std::error_code ec;
  if (!fs::is_directory(parent, ec)) {
    throw Error(
        StrCat(path.string(), ": cannot write: folder ", parent.string(), " does not exist"));
  }
  if (::access(parent.c_str(), W_OK) != 0) {
    throw Error(
        StrCat(path.string(), ": cannot write: folder ", parent.string(), " is not writable"));
  }
}

fs::path Canonical(const fs::path& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(fs::absolute(p, ec), ec);
  return ec ? fs::absolute(p).lexically_normal() : c;
}

// True when `inner` is `outer` or lies below it (both canonical).
bool IsWithin(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
    if (o->empty()) continue;  // trailing separator
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

// Where an input folder's files really are: the folder and the resolved targets of the links
// below it (a view's left/ may link to the capture's own folder, an image to a file elsewhere),
// followed into linked folders once each (no loops). At most kMaxEntries entries are visited: an
// input that large is checked at the places reached until then.
std::vector<fs::path> PlacesOfInputFolder(const fs::path& canonical_folder) {
  constexpr size_t kMaxEntries = 200000;
  std::vector<fs::path> places = {canonical_folder};
  size_t visited = 0;
  for (size_t k = 0; k < places.size() && visited < kMaxEntries; ++k) {
    std::error_code ec;
    if (!fs::is_directory(places[k], ec)) continue;
    fs::recursive_directory_iterator it(places[k], fs::directory_options::skip_permission_denied,
                                        ec);
    for (; !ec && it != fs::recursive_directory_iterator() && visited < kMaxEntries;
         it.increment(ec), ++visited) {
      std::error_code lec;
      if (!it->is_symlink(lec)) continue;
      const fs::path target = fs::canonical(it->path(), lec);
      if (lec) continue;  // dangling or a loop: reads nothing
      bool known = false;
      for (const fs::path& p : places) known = known || IsWithin(target, p);
      if (!known) places.push_back(target);
    }
  }
  return places;
}

void CheckNotAnInput(const fs::path& output, const std::vector<fs::path>& inputs,
                     bool output_is_folder) {
  const fs::path out = Canonical(output);
  for (const fs::path& input : inputs) {
    if (input.empty()) continue;
    const fs::path in = Canonical(input);
    std::error_code ec;
    const bool same = out == in || fs::equivalent(output, input, ec);
    if (same) {
      throw Error(StrCat(output.string(), ": is also an input of this command (", input.string(),
                         "); an output never replaces an input"));
    }
    const std::vector<fs::path> places =
        fs::is_directory(input, ec) ? PlacesOfInputFolder(in) : std::vector<fs::path>{};
    for (const fs::path& place : places) {
      if (output_is_folder && IsWithin(place, out)) {
        throw Error(StrCat(output.string(), ": contains the input ", input.string(),
                           place == in ? "" : StrCat(" (linked from it: ", place.string(), ")"),
                           "; replacing the folder would delete it (choose another output "
                           "folder)"));
      }
      // Nothing is written inside an input folder, also through a link: a file there (a view's
      // image, a scan's calibration) may be read by this command, and a new file or folder
      // changes what the folder holds (a scan folder with an extra view folder no longer matches
      // its scan.json; a registration folder with an extra cloud fuses it next time).
      if (IsWithin(out, place)) {
        throw Error(StrCat(output.string(), ": lies inside the input folder ", input.string(),
                           place == in ? "" : StrCat(" (linked from it: ", place.string(), ")"),
                           "; an output is never written into an input (choose a place outside "
                           "it)"));
      }
    }
    if (output_is_folder && places.empty() && IsWithin(in, out)) {
      throw Error(StrCat(output.string(), ": contains the input ", input.string(),
                         "; replacing the folder would delete it (choose another output folder)"));
    }
  }
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// A name is printed in messages with non-printable bytes escaped, so that a hostile name cannot
// garble the terminal.
std::string Printable(const std::string& s) {
  std::string out;
  for (unsigned char c : s.substr(0, 200)) {
    if (c < 0x20 || c == 0x7f) {
      out += StrCat("\\x", "0123456789abcdef"[c >> 4], "0123456789abcdef"[c & 15]);
    } else {
      out += static_cast<char>(c);
    }
  }
  if (s.size() > 200) out += "...";
  return out;
}

// `s` with every occurrence of `from` replaced by `to`.
std::string ReplaceAll(std::string s, const std::string& from, const std::string& to) {
  if (from.empty()) return s;
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) {
    s.replace(at, from.size(), to);
  }
  return s;
}

// Runs body(), which writes to the temporary `tmp` of the output `path`, and rethrows its errors
// naming `path`: a filesystem error (e.g. "No space left on device") as "<path>: cannot write:
// <reason>", a fringe::Error (a writer's checked close names the file it was handed) with `tmp`
// replaced by `path`. The user never sees the hidden name; other exceptions pass unchanged.
void NamingTheOutput(const fs::path& tmp, const fs::path& path, const std::function<void()>& body) {
  try {
    body();
  } catch (const fs::filesystem_error& e) {
    throw Error(StrCat(path.string(), ": cannot write: ", e.code().message()));
  } catch (const Error& e) {
    throw Error(ReplaceAll(e.what(), tmp.string(), path.string()));
  }
}

// Test hook for crash consistency (tests/hostile/kill_outputs.py): every step of committing an
// output is a checkpoint. FRINGE_TEST_CHECKPOINTS=FILE appends one line per checkpoint to FILE
// (to count them); FRINGE_TEST_KILL_AT=N ends the process with SIGKILL at the Nth, as a power
// cut or the OOM killer would at that moment. Both unset (always, outside that test): nothing.
void OutputCheckpoint(const char* what) {
  static const long kill_at = [] {
    const char* v = std::getenv("FRINGE_TEST_KILL_AT");
    return v ? std::atol(v) : 0L;
  }();
  static const char* log = std::getenv("FRINGE_TEST_CHECKPOINTS");
  if (kill_at <= 0 && log == nullptr) return;
  static std::atomic<long> count{0};
  const long n = ++count;
  if (log != nullptr) {
    static std::mutex mutex;
    const std::lock_guard<std::mutex> lock(mutex);
    std::ofstream(log, std::ios::app) << n << " " << what << "\n";
  }
  if (n == kill_at) ::raise(SIGKILL);
}

// Crash consistency: the bytes of an output reach the disk before its name does. Without this a
// power cut after the rename can leave a "complete" output holding empty or torn files (the
// rename's metadata is journaled before the data is written back). fsync(2) on a file opened
// read-only flushes its data; on a folder, its entries (the rename). An error is reported as a
// write error of `shown` (the user's name, not the temporary's).
void SyncPath(const fs::path& path, const fs::path& shown) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(StrCat(shown.string(), ": cannot write: ", std::strerror(errno)));
  // EINVAL/EROFS: the file system does not support syncing (a pseudo or read-only one): nothing
  // to make durable there.
  if (::fsync(fd) != 0 && errno != EINVAL && errno != EROFS) {
    const int err = errno;
    ::close(fd);
    throw Error(StrCat(shown.string(), ": cannot write: ", std::strerror(err)));
  }
  ::close(fd);
}

// Every file and folder below `root` (a finished temporary output folder), then `root` itself.
void SyncTree(const fs::path& root, const fs::path& shown) {
  std::error_code ec;
  for (fs::recursive_directory_iterator it(root, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code sec;
    const fs::file_status st = it->symlink_status(sec);
    if (fs::is_regular_file(st) || fs::is_directory(st)) {
      SyncPath(it->path(), shown / it->path().lexically_relative(root));
    }
  }
  if (ec) throw Error(StrCat(shown.string(), ": cannot write: ", ec.message()));
  SyncPath(root, shown);
}

// The folder holding `path`, after a rename into it.
void SyncParent(const fs::path& path) {
  const fs::path parent = fs::absolute(path).parent_path();
  SyncPath(parent.empty() ? fs::path(".") : parent, path);
}

}  // namespace

void CloseOutput(std::ofstream& out, const fs::path& path) {
  // The stream keeps only a failbit/badbit: the reason is errno of the write(2) that failed,
  // either an earlier one (still in errno: later calls on a failed stream do nothing) or the
  // one flushing the buffer at close.
  const int err_before = errno;
  const bool failed_before = !out;
  errno = 0;
  out.close();
  if (!failed_before && out) return;
  const int err = errno != 0 ? errno : (failed_before ? err_before : 0);
  throw Error(StrCat(path.string(), ": cannot write: ",
                     err != 0 ? std::strerror(err) : "write error (disk full?)"));
}

void WriteAtomically(const fs::path& path, const std::function<void(const fs::path&)>& write) {
  RequireWritableParent(path);
  std::error_code sec;
  if (fs::is_directory(path, sec)) {
    throw Error(StrCat(path.string(), ": cannot write: is a folder"));
  }
  RemoveStaleTemporaries(path);
  const fs::path tmp = TemporarySibling(path);
  const TemporaryRegistration registration(tmp);
  try {
    NamingTheOutput(tmp, path, [&] {
      write(tmp);
      OutputCheckpoint("file written");
      SyncPath(tmp, path);
      OutputCheckpoint("file synced");
      std::error_code ec;
      fs::rename(tmp, path, ec);
      if (ec) throw Error(StrCat(path.string(), ": cannot write: ", ec.message()));
      OutputCheckpoint("file renamed");
      SyncParent(path);
    });
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
}

void WriteFolderAtomically(const fs::path& dir, const OutputFolderOptions& options,
                           const std::function<void(const fs::path&)>& write) {
  CheckOutputFolder(dir, options);
  const fs::path tmp = TemporarySibling(dir);
  const TemporaryRegistration registration(tmp);
  if (options.resume) TakeOverStaleTemporary(dir, tmp);
  RemoveStaleTemporaries(dir);
  try {
    NamingTheOutput(tmp, dir, [&] {
      fs::create_directories(tmp);
      {
        std::ofstream marker(tmp / kOutputMarkerName);
        marker << "written by fringe; a later fringe run may replace this folder\n";
        CloseOutput(marker, dir / kOutputMarkerName);
      }
      write(tmp);
      SyncTree(tmp, dir);
      std::error_code ec;
      OutputCheckpoint("folder written and synced");
      if (fs::exists(fs::symlink_status(dir))) {
        // One atomic exchange of the new folder and the old one: a crash at any moment leaves
        // the old output or the new one under the name, never none (the old one would then sit
        // under a temporary name that the next run removes).
        if (::renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, dir.c_str(), RENAME_EXCHANGE) == 0) {
          OutputCheckpoint("folder exchanged");
          SyncParent(dir);
          fs::remove_all(tmp, ec);  // now the old output
        } else if (errno == EINVAL || errno == ENOSYS || errno == ENOTSUP) {
          // A file system without the exchange: keep the old folder until the new one is in.
          const fs::path old = TemporarySibling(dir);
          const TemporaryRegistration old_registration(old);
          fs::rename(dir, old, ec);
          if (ec) throw Error(StrCat(dir.string(), ": cannot replace: ", ec.message()));
          fs::rename(tmp, dir, ec);
          if (ec) {
            fs::rename(old, dir);
            throw Error(StrCat(dir.string(), ": cannot write: ", ec.message()));
          }
          SyncParent(dir);
          fs::remove_all(old, ec);
        } else {
          throw Error(StrCat(dir.string(), ": cannot replace: ", std::strerror(errno)));
        }
      } else {
        fs::rename(tmp, dir, ec);
        if (ec) throw Error(StrCat(dir.string(), ": cannot write: ", ec.message()));
        OutputCheckpoint("folder renamed");
        SyncParent(dir);
      }
    });
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(tmp, ignored);
    throw;
  }
}

OutputTransaction::~OutputTransaction() {
  for (const Entry& e : entries_) {
    std::error_code ignored;
    fs::remove_all(e.tmp, ignored);
  }
}

fs::path OutputTransaction::Stage(const fs::path& path) {
  CheckOutputFile(path);
  for (const Entry& e : entries_) {
    if (Canonical(e.path) == Canonical(path)) {
      throw Error(StrCat(path.string(), ": given for two outputs of this command"));
    }
  }
  RemoveStaleTemporaries(path);
  Entry e;
  e.path = path;
  e.tmp = TemporarySibling(path);
  e.signal_cleanup = std::make_shared<TemporaryRegistration>(e.tmp);
  entries_.push_back(std::move(e));
  return entries_.back().tmp;
}

void OutputTransaction::Write(const fs::path& path,
                              const std::function<void(const fs::path&)>& write) {
  const fs::path tmp = Stage(path);
  NamingTheOutput(tmp, path, [&] { write(tmp); });
}

void OutputTransaction::Commit() {
  for (const Entry& e : entries_) {
    std::error_code ec;
    if (!fs::exists(e.tmp, ec)) throw Error(StrCat(e.path.string(), ": was not written"));
    if (fs::is_directory(e.tmp, ec)) {
      SyncTree(e.tmp, e.path);
    } else {
      SyncPath(e.tmp, e.path);
    }
  }
  for (const Entry& e : entries_) {
    OutputCheckpoint("transaction: before a rename");
    std::error_code ec;
    fs::rename(e.tmp, e.path, ec);
    if (ec) throw Error(StrCat(e.path.string(), ": cannot write: ", ec.message()));
  }
  for (const Entry& e : entries_) SyncParent(e.path);
  entries_.clear();
}

void CheckOutputFile(const fs::path& path, const std::vector<fs::path>& inputs) {
  if (path.empty()) throw Error("empty output path");
  RequireWritableParent(path);
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw Error(StrCat(path.string(), ": cannot write: is a folder"));
  CheckNotAnInput(path, inputs, /*output_is_folder=*/false);
}

void CheckOutputFolder(const fs::path& dir, const OutputFolderOptions& options) {
  if (dir.empty()) throw Error("empty output folder path");
  RequireWritableParent(dir);
  CheckNotAnInput(dir, options.inputs, /*output_is_folder=*/true);
  std::error_code ec;
  const fs::file_status st = fs::symlink_status(dir, ec);
  if (!fs::exists(st)) return;
  if (!fs::is_directory(fs::status(dir, ec))) {
    throw Error(StrCat(dir.string(), ": exists and is not a folder; refusing to replace it"));
  }
  if (fs::is_empty(dir, ec) || fs::exists(dir / kOutputMarkerName, ec)) return;
  if (options.legacy_layout && options.legacy_layout(dir)) return;
  throw Error(StrCat(dir.string(), ": exists and was not written by fringe (no ", kOutputMarkerName,
                     " marker); refusing to replace it: choose a new output folder or remove "
                     "this one yourself"));
}

void CheckDistinctOutputs(const std::vector<fs::path>& outputs) {
  for (size_t i = 0; i < outputs.size(); ++i) {
    for (size_t k = i + 1; k < outputs.size(); ++k) {
      if (!outputs[i].empty() && !outputs[k].empty() &&
          Canonical(outputs[i]) == Canonical(outputs[k])) {
        throw Error(StrCat(outputs[k].string(), ": given for two outputs of this command"));
      }
    }
  }
}

void CheckRelativeName(const std::string& name, const std::string& context,
                       const std::vector<std::string>& extensions, const std::string& what) {
  auto fail = [&](const std::string& problem) {
    throw Error(StrCat(context, ": ", what, " '", Printable(name), "': ", problem));
  };
  if (name.empty()) fail("empty name");
  if (name.size() > 1024) fail("longer than 1024 characters");
  for (unsigned char c : name) {
    if (c < 0x20 || c == 0x7f) fail("contains a control character");
    if (c == '\\') fail("contains a backslash (use '/' between folders)");
  }
  if (name.front() == '/') fail("absolute path (names must be relative to their folder)");
  size_t start = 0;
  while (start <= name.size()) {
    const size_t end = std::min(name.find('/', start), name.size());
    const std::string component = name.substr(start, end - start);
    if (component.empty()) fail("empty path component");
    if (component == ".") fail("'.' path component");
    if (component == "..") fail("'..' path component (names must stay inside their folder)");
    start = end + 1;
  }
  if (!extensions.empty() && !HasExtension(fs::path(name), extensions)) {
    std::string list;
    for (const auto& e : extensions) list += (list.empty() ? "" : " ") + e;
    fail(StrCat("unknown extension (expected one of ", list, ")"));
  }
}

void CheckRelativeNames(const std::vector<std::string>& names, const std::string& context,
                        const std::vector<std::string>& extensions, const std::string& what) {
  std::set<std::string> seen;
  for (const std::string& name : names) {
    CheckRelativeName(name, context, extensions, what);
    if (!seen.insert(name).second) {
      throw Error(StrCat(context, ": ", what, " '", Printable(name), "' appears twice"));
    }
  }
}

const std::vector<std::string>& ImageExtensions() {
  static const std::vector<std::string> extensions = {".png",  ".tif", ".tiff", ".bmp", ".jpg",
                                                      ".jpeg", ".pgm", ".ppm",  ".pnm"};
  return extensions;
}

bool HasExtension(const fs::path& path, const std::vector<std::string>& extensions) {
  const std::string ext = Lower(path.extension().string());
  return std::find(extensions.begin(), extensions.end(), ext) != extensions.end();
}

void RequireFile(const fs::path& path, const std::string& what) {
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    if (ec == std::errc::too_many_symbolic_link_levels) {
      throw Error(StrCat(path.string(), ": ", what, ": symbolic link loop"));
    }
    throw Error(StrCat(path.string(), ": ", what, ": no such file"));
  }
  if (!fs::is_regular_file(path, ec)) {
    throw Error(StrCat(path.string(), ": ", what, ": not a regular file"));
  }
}

void RequireDirectory(const fs::path& path, const std::string& what) {
  std::error_code ec;
  if (!fs::is_directory(path, ec)) {
    throw Error(StrCat(path.string(), ": ", what, ": no such folder"));
  }
}

std::uintmax_t FileSizeBytes(const fs::path& path) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw Error(StrCat(path.string(), ": cannot read: ", ec.message()));
  return size;
}

std::string ReadTextFile(const fs::path& path, std::uintmax_t max_bytes) {
  RequireFile(path);
  const std::uintmax_t size = FileSizeBytes(path);
  if (size > max_bytes) {
    throw Error(StrCat(path.string(), ": ", size, " bytes, larger than the limit of ", max_bytes,
                       " bytes for this kind of file"));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(StrCat(path.string(), ": cannot open for reading"));
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw Error(StrCat(path.string(), ": read error"));
  return ss.str();
}

bool EnvFlag(const char* name) {
  const char* v = std::getenv(name);
  if (v == nullptr) return false;
  const std::string s(v);
  return !(s.empty() || s == "0" || s == "false" || s == "OFF" || s == "off");
}

}  // namespace fringe::util
