#include "fringe/io/json.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>

#include "fringe/util/files.h"

namespace fringe::io {
namespace {

using nlohmann::json;
using util::StrCat;

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t k = 0; k <= b.size(); ++k) prev[k] = k;
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (size_t k = 1; k <= b.size(); ++k) {
      cur[k] = std::min({prev[k] + 1, cur[k - 1] + 1, prev[k - 1] + (a[i - 1] != b[k - 1])});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string Field(const std::string& context, const char* key) { return StrCat(context, ".", key); }

const char* TypeName(const json& v) { return v.type_name(); }

}  // namespace

json ParseJson(const std::string& text, const std::string& context) {
  // The callback sees every value with its depth before the value is kept: refusing deep values
  // there bounds both the parser's work and every later recursive walk (dump, destruction).
  const json::parser_callback_t bound_depth = [&](int depth, json::parse_event_t, json&) {
    if (depth > util::kMaxNestingDepth) {
      throw Error(StrCat(context, ": JSON nested deeper than ", util::kMaxNestingDepth, " levels"));
    }
    return true;
  };
  try {
    return json::parse(text, bound_depth);
  } catch (const json::exception& e) {
    // parse_error, and out_of_range for numbers such as 1e999.
    throw Error(StrCat(context, ": invalid JSON: ", e.what()));
  }
}

json ReadJson(const std::filesystem::path& path, std::uintmax_t max_bytes) {
  return ParseJson(util::ReadTextFile(path, max_bytes), path.string());
}

void WriteJson(const std::filesystem::path& path, const json& j) {
  util::WriteAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp);
    // Strings from the user (file names) need not be UTF-8: replace bad bytes, never fail.
    out << j.dump(2, ' ', false, json::error_handler_t::replace) << "\n";
    util::CloseOutput(out, path);
  });
}

std::string Brief(const json& j, size_t max_chars) {
  std::string s;
  if (j.is_array() || j.is_object()) {
    // Do not dump an arbitrarily large value only to cut it: its first elements suffice.
    s = j.is_array() ? "[" : "{";
    size_t n = 0;
    for (auto it = j.begin(); it != j.end() && s.size() <= max_chars; ++it, ++n) {
      if (n) s += ",";
      if (j.is_object()) s += json(it.key()).dump() + ":";
      s += Brief(*it, max_chars);
    }
    s += j.is_array() ? "]" : "}";
  } else {
    s = j.dump(-1, ' ', false, json::error_handler_t::replace);
  }
  if (s.size() > max_chars) s = s.substr(0, max_chars) + "...";
  return s;
}

std::vector<std::string> NearestKeys(const std::string& key,
                                     const std::vector<std::string>& known) {
  const std::string k = Lower(key);
  // A shortened key ("radius_mm") is as likely to mean any key that contains it
  // (outer_radius_mm, inner_radius_mm, dot_radius_mm): name them all, in the format's order.
  std::vector<std::string> containing;
  for (const std::string& candidate : known) {
    if (k.size() >= 3 && Lower(candidate).find(k) != std::string::npos) {
      containing.push_back(candidate);
    }
  }
  if (containing.size() > 1) return containing;
  std::vector<std::string> best;
  size_t best_score = std::numeric_limits<size_t>::max();
  for (const std::string& candidate : known) {
    const std::string c = Lower(candidate);
    size_t d = EditDistance(k, c);
    const bool related = c.find(k) != std::string::npos || k.find(c) != std::string::npos;
    // A misspelling changes a few characters; a shortened or extended key contains the other.
    if (!related && d > std::max<size_t>(2, std::min(k.size(), c.size()) / 3)) continue;
    if (related) d = std::min(d, std::max(k.size(), c.size()) - std::min(k.size(), c.size()));
    if (d < best_score) {
      best_score = d;
      best = {candidate};
    } else if (d == best_score) {
      best.push_back(candidate);
    }
  }
  return best;
}

void CheckKnownKeys(const json& j, const std::vector<std::string>& known,
                    const std::string& context) {
  RequireObject(j, context);
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (std::find(known.begin(), known.end(), it.key()) != known.end()) continue;
    const std::vector<std::string> nearest = NearestKeys(it.key(), known);
    std::string list, suggestion;
    for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
    for (size_t i = 0; i < nearest.size(); ++i) {
      suggestion += StrCat(i == 0                    ? ""
                           : i + 1 == nearest.size() ? " or "
                                                     : ", ",
                           "'", nearest[i], "'");
    }
    throw Error(StrCat(context, ": unknown key ", Brief(json(it.key())),
                       nearest.empty() ? "" : StrCat(" (did you mean ", suggestion, "?)"),
                       "; known keys: ", list));
  }
}

void CheckKnownKeys(const json& j, std::initializer_list<const char*> known,
                    const std::string& context) {
  CheckKnownKeys(j, std::vector<std::string>(known.begin(), known.end()), context);
}

void RequireObject(const json& j, const std::string& context) {
  if (!j.is_object()) {
    throw Error(StrCat(context, ": expected a JSON object, found ", TypeName(j)));
  }
}

double AsNumber(const json& v, const std::string& where) {
  if (!v.is_number()) {
    throw Error(StrCat(where, ": expected a number, found ", TypeName(v), " ", Brief(v)));
  }
  const double x = v.get<double>();
  if (!std::isfinite(x)) throw Error(StrCat(where, ": not a finite number"));
  return x;
}

long long AsInteger(const json& v, long long lo, long long hi, const std::string& where) {
  if (!v.is_number_integer()) {
    throw Error(StrCat(where, ": expected an integer, found ",
                       v.is_number() ? "a non-integer number" : TypeName(v), " ", Brief(v)));
  }
  long long x;
  if (v.is_number_unsigned()) {
    const auto u = v.get<unsigned long long>();
    if (u > static_cast<unsigned long long>(std::numeric_limits<long long>::max())) {
      throw Error(StrCat(where, " = ", u, ": must be in [", lo, ", ", hi, "]"));
    }
    x = static_cast<long long>(u);
  } else {
    x = v.get<long long>();
  }
  if (x < lo || x > hi) throw Error(StrCat(where, " = ", x, ": must be in [", lo, ", ", hi, "]"));
  return x;
}

std::string AsString(const json& v, const std::string& where) {
  if (!v.is_string()) {
    throw Error(StrCat(where, ": expected a string, found ", TypeName(v), " ", Brief(v)));
  }
  return v.get<std::string>();
}

double GetNumber(const json& j, const char* key, const std::string& context) {
  RequireObject(j, context);
  if (!j.contains(key)) throw Error(StrCat(context, ": missing field '", key, "'"));
  return AsNumber(j[key], Field(context, key));
}

std::vector<double> GetNumbers(const json& j, const char* key, size_t count,
                               const std::string& context) {
  RequireObject(j, context);
  if (!j.contains(key)) throw Error(StrCat(context, ": missing field '", key, "'"));
  const json& a = j[key];
  const std::string where = Field(context, key);
  if (!a.is_array() || a.size() != count) {
    throw Error(StrCat(where, ": expected an array of ", count, " numbers, found ", Brief(a)));
  }
  std::vector<double> out;
  for (size_t k = 0; k < count; ++k) out.push_back(AsNumber(a[k], StrCat(where, "[", k, "]")));
  return out;
}

double OptionalNumber(const json& j, const char* key, double fallback, const std::string& context) {
  RequireObject(j, context);
  return j.contains(key) ? AsNumber(j[key], Field(context, key)) : fallback;
}

long long GetInteger(const json& j, const char* key, long long lo, long long hi,
                     const std::string& context) {
  RequireObject(j, context);
  if (!j.contains(key)) throw Error(StrCat(context, ": missing field '", key, "'"));
  return AsInteger(j[key], lo, hi, Field(context, key));
}

long long OptionalInteger(const json& j, const char* key, long long fallback, long long lo,
                          long long hi, const std::string& context) {
  RequireObject(j, context);
  return j.contains(key) ? AsInteger(j[key], lo, hi, Field(context, key)) : fallback;
}

bool GetBool(const json& j, const char* key, const std::string& context) {
  RequireObject(j, context);
  if (!j.contains(key)) throw Error(StrCat(context, ": missing field '", key, "'"));
  if (!j[key].is_boolean()) {
    throw Error(StrCat(Field(context, key), ": expected true or false, found ", Brief(j[key])));
  }
  return j[key].get<bool>();
}

bool OptionalBool(const json& j, const char* key, bool fallback, const std::string& context) {
  RequireObject(j, context);
  return j.contains(key) ? GetBool(j, key, context) : fallback;
}

std::string GetString(const json& j, const char* key, const std::string& context) {
  RequireObject(j, context);
  if (!j.contains(key)) throw Error(StrCat(context, ": missing field '", key, "'"));
  return AsString(j[key], Field(context, key));
}

std::string OptionalString(const json& j, const char* key, const std::string& fallback,
                           const std::string& context) {
  RequireObject(j, context);
  return j.contains(key) ? AsString(j[key], Field(context, key)) : fallback;
}

}  // namespace fringe::io
