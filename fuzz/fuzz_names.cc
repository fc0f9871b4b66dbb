// Names from data files (manifest images, scan-folder files): the path-escape check must never
// accept a name that leaves its folder.
#include <cstdlib>
#include <filesystem>

#include "fringe/util/error.h"
#include "fringe/util/files.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string name(reinterpret_cast<const char*>(data), size);
  try {
    fringe::util::CheckRelativeName(name, "fuzz");
  } catch (const fringe::Error&) {
    return 0;
  }
  // Accepted: joined to a folder it must stay inside it, lexically.
  const std::filesystem::path base("/base/folder");
  const std::string joined = (base / name).lexically_normal().string();
  if (joined.rfind("/base/folder/", 0) != 0) std::abort();
  return 0;
}
