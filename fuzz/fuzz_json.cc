// Every JSON format: the bounded parser, then each reader on the value (rig, target, scheme, and
// the scan folder's manifest, truth poses, markers and scene).
#include "fringe/io/calibration_io.h"
#include "fringe/io/json.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/scan/truth.h"
#include "fringe/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  nlohmann::json j;
  try {
    j = fringe::io::ParseJson(std::string(reinterpret_cast<const char*>(data), size), "fuzz.json");
  } catch (const fringe::Error&) {
    return 0;
  }
  try {
    fringe::io::RigFromJson(j, "fuzz.json");
  } catch (const fringe::Error&) {
  }
  try {
    fringe::io::TargetFromJson(j, "fuzz.json");
  } catch (const fringe::Error&) {
  }
  try {
    fringe::phase::SchemeFromJson(j, "fuzz.json");
  } catch (const fringe::Error&) {
  }
  try {
    fringe::scan::ManifestFromJson(j, "fuzz.json");
  } catch (const fringe::Error&) {
  }
  try {
    fringe::scan::PosesFromJson(j, "fuzz.json");
  } catch (const fringe::Error&) {
  }
  try {
    fringe::scan::MarkersFromJson(j, "fuzz.json");
  } catch (const fringe::Error&) {
  }
  try {
    fringe::scan::SceneFromJson(j, "fuzz.json");
  } catch (const fringe::Error&) {
  }
  (void)fringe::io::Brief(j);
  return 0;
}
