// The registration's own files: a view's markers file (OUT.markers.json) through the bounded JSON
// parser and its reader. poses.json and the marker map share the scan folder's readers, which
// fuzz_json covers.
#include "fringe/io/json.h"
#include "fringe/registration/markers.h"
#include "fringe/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const nlohmann::json j = fringe::io::ParseJson(
        std::string(reinterpret_cast<const char*>(data), size), "fuzz.markers.json");
    fringe::registration::ViewMarkersFromJson(j, "fuzz.markers.json");
  } catch (const fringe::Error&) {
  }
  return 0;
}
