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

}  // namespace util
}  // namespace fringe
