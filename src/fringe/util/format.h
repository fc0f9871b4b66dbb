// Numbers in summaries and messages, written one way everywhere.
//
// Thread safety: the functions are reentrant.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace fringe::util {

// `v` with exactly `digits` digits after the decimal point ("0.068" for (0.0678, 3)); "nan" and
// "inf" as the stream writes them.
std::string Fixed(double v, int digits);

// A figure for a summary's JSON: the number when finite, null when not (NaN: not measured).
// nlohmann::json would write NaN as null anyway, but silently; this says it.
nlohmann::json FigureOrNull(double v);

}  // namespace fringe::util
