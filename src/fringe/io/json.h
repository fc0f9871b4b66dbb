// Strict, bounded JSON reading shared by every JSON reader (rig, target, scheme manifest, scan
// folder, poses, markers, ...). Inputs are untrusted (docs/formats.md, "Untrusted inputs"):
//  - ReadJson / ParseJson bound the file size and the nesting depth (util::kMaxNestingDepth)
//    before building anything, so a few kilobytes cannot exhaust memory or the stack;
//  - CheckKnownKeys rejects keys a format does not define, naming the nearest valid one
//    ("unknown key 'radius_mm' (did you mean 'outer_radius_mm'?)");
//  - the typed getters reject wrong types, non-integers (4.5), out-of-range integers
//    (4294967936 for an int) and non-finite numbers, naming "<context>.<key>";
//  - Brief() prints a value from a file in bounded length for messages.
// Thread safety: pure functions.
#pragma once

#include <filesystem>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/util/error.h"

namespace fringe::io {

// Reads JSON from a file (at most max_bytes, nesting at most util::kMaxNestingDepth) with
// errors naming the file; writes JSON atomically, pretty printed.
nlohmann::json ReadJson(const std::filesystem::path& path,
                        std::uintmax_t max_bytes = std::uintmax_t{64} << 20);
// Parses text with the same bounds; `context` names the source in errors.
nlohmann::json ParseJson(const std::string& text, const std::string& context);
void WriteJson(const std::filesystem::path& path, const nlohmann::json& j);

// At most max_chars characters of j.dump() (with "..." when cut), for error messages.
std::string Brief(const nlohmann::json& j, size_t max_chars = 60);

// Throws fringe::Error("<context>: unknown key '<k>' (did you mean '<nearest>'?; known keys:
// ...)") for the first key of object `j` not in `known`. `j` must be an object.
void CheckKnownKeys(const nlohmann::json& j, std::initializer_list<const char*> known,
                    const std::string& context);
void CheckKnownKeys(const nlohmann::json& j, const std::vector<std::string>& known,
                    const std::string& context);
// The entries of `known` that `key` plausibly misspells (case insensitive): every entry that
// contains `key` when several do (a shortened key), else those nearest by edit distance; empty
// when none is plausible.
std::vector<std::string> NearestKeys(const std::string& key, const std::vector<std::string>& known);

// Throws "<context>: expected a JSON object" unless j is an object.
void RequireObject(const nlohmann::json& j, const std::string& context);

// Typed field access: Get* throw "<context>: missing field '<key>'" when absent; Optional*
// return `fallback` when absent. All throw "<context>.<key>: ..." for a wrong type or value.
double GetNumber(const nlohmann::json& j, const char* key, const std::string& context);
double OptionalNumber(const nlohmann::json& j, const char* key, double fallback,
                      const std::string& context);
// An integer in [lo, hi]: a JSON integer (not 4.5, not 4.0e0), in range.
long long GetInteger(const nlohmann::json& j, const char* key, long long lo, long long hi,
                     const std::string& context);
long long OptionalInteger(const nlohmann::json& j, const char* key, long long fallback,
                          long long lo, long long hi, const std::string& context);
bool GetBool(const nlohmann::json& j, const char* key, const std::string& context);
bool OptionalBool(const nlohmann::json& j, const char* key, bool fallback,
                  const std::string& context);
std::string GetString(const nlohmann::json& j, const char* key, const std::string& context);
std::string OptionalString(const nlohmann::json& j, const char* key, const std::string& fallback,
                           const std::string& context);

// j[key] as an array of exactly `count` finite numbers (a point, a pixel, a normal); throws
// "<context>.<key>: ..." naming what is wrong.
std::vector<double> GetNumbers(const nlohmann::json& j, const char* key, size_t count,
                               const std::string& context);

// Value-level versions (for array elements): `where` names the value ("<context>.images[3]").
double AsNumber(const nlohmann::json& v, const std::string& where);
long long AsInteger(const nlohmann::json& v, long long lo, long long hi, const std::string& where);
std::string AsString(const nlohmann::json& v, const std::string& where);

// Runs parse() and rethrows nlohmann::json exceptions, and fringe::Errors that do not already
// start with `context`, as fringe::Error("<context>: <what>"), so every JSON reader names the
// file and field the same way.
template <typename Parse>
auto WithJsonContext(const std::string& context, Parse&& parse) -> decltype(parse()) {
  try {
    return parse();
  } catch (const nlohmann::json::exception& e) {
    throw Error(context + ": " + e.what());
  } catch (const Error& e) {
    const std::string msg = e.what();
    if (msg.rfind(context, 0) == 0) throw;
    throw Error(context + ": " + msg);
  }
}

}  // namespace fringe::io
