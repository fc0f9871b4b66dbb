#include "fringe/util/files.h"

#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "fringe/util/error.h"

namespace fringe::util {
namespace {

fs::path TemporarySibling(const fs::path& path) {
  static std::atomic<int> counter{0};
  const fs::path parent = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  // ".<name>.tmp<pid>_<n><ext>": hidden, unique per process and call, keeps the extension.
  std::string name = StrCat(".", path.stem().string(), ".tmp", ::getpid(), "_", counter++,
                            path.extension().string());
  return parent / name;
}

void RequireWritableParent(const fs::path& path) {
  const fs::path parent = path.parent_path().empty() ? fs::path(".") : path.parent_path();
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

}  // namespace

void WriteAtomically(const fs::path& path, const std::function<void(const fs::path&)>& write) {
  RequireWritableParent(path);
  const fs::path tmp = TemporarySibling(path);
  try {
    write(tmp);
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) throw Error(StrCat(path.string(), ": cannot write: ", ec.message()));
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
}

void WriteFolderAtomically(const fs::path& dir, const std::function<void(const fs::path&)>& write) {
  RequireWritableParent(dir);
  const fs::path tmp = TemporarySibling(dir);
  try {
    fs::create_directories(tmp);
    write(tmp);
    std::error_code ec;
    if (fs::exists(dir)) {
      // Keep the old folder until the new one is in place.
      const fs::path old = TemporarySibling(dir);
      fs::rename(dir, old, ec);
      if (ec) throw Error(StrCat(dir.string(), ": cannot replace: ", ec.message()));
      fs::rename(tmp, dir, ec);
      if (ec) {
        fs::rename(old, dir);
        throw Error(StrCat(dir.string(), ": cannot write: ", ec.message()));
      }
      fs::remove_all(old, ec);
    } else {
      fs::rename(tmp, dir, ec);
      if (ec) throw Error(StrCat(dir.string(), ": cannot write: ", ec.message()));
    }
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(tmp, ignored);
    throw;
  }
}

void RequireFile(const fs::path& path, const std::string& what) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error(StrCat(path.string(), ": ", what, ": no such file"));
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

std::string ReadTextFile(const fs::path& path) {
  RequireFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(StrCat(path.string(), ": cannot open for reading"));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool EnvFlag(const char* name) {
  const char* v = std::getenv(name);
  if (v == nullptr) return false;
  const std::string s(v);
  return !(s.empty() || s == "0" || s == "false" || s == "OFF" || s == "off");
}

}  // namespace fringe::util
