// Errors and option checks shared by every module.
//
// Three kinds of failure (docs/architecture.md): bad input or options throw fringe::Error with a
// message a user understands (which file, which field, what was expected); expected data
// failures come back as a status in a Summary; broken internal invariants are assert()s.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace fringe {

// Thrown for bad input files, bad options and unwritable outputs. The message is complete and
// meant to be printed as is (the CLI prefixes "fringe: error: ").
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace util {

// Concatenates arguments with operator<< into a string.
template <typename... Args>
std::string StrCat(const Args&... args) {
  std::ostringstream os;
  (os << ... << args);
  return os.str();
}

// Throws fringe::Error("<options>.<field> = <value>: <constraint>") when !ok. Used by every
// FooOptions::Check() so the message names the field and the violated constraint.
template <typename T>
void CheckOption(bool ok, const char* options, const char* field, const T& value,
                 const char* constraint) {
  if (!ok) {
    throw Error(StrCat(options, ".", field, " = ", value, ": ", constraint));
  }
}

// Sane upper bounds for sizes read from files and flags, checked before anything is allocated
// (a few hundred bytes of header must not make fringe allocate gigabytes). Generous for real
// sensors: cameras used for fringe projection stay below 50 Mpx and 16k pixels a side.
inline constexpr long long kMaxImageSidePx = 1 << 15;    // width or height of an image
inline constexpr long long kMaxImagePixels = 1LL << 26;  // 67 Mpx
inline constexpr long long kMaxStackImages = 4096;       // images in one fringe stack
inline constexpr int kMaxNestingDepth = 64;              // JSON / YAML / XML nesting

// Throws fringe::Error("<context>: <field> = <value>: must be in [lo, hi]<why>") unless
// lo <= value <= hi. For sizes and integers read from files and flags.
inline void CheckRange(long long value, long long lo, long long hi, const std::string& context,
                       const std::string& field, const std::string& why = "") {
  if (value < lo || value > hi) {
    throw Error(StrCat(context, ": ", field, " = ", value, ": must be in [", lo, ", ", hi, "]",
                       why.empty() ? "" : " (", why, why.empty() ? "" : ")"));
  }
}

}  // namespace util
}  // namespace fringe
