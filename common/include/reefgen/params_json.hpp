#pragma once
// reefgen's one params mechanism (docs/DESIGN.md §2): a params struct P
// declares its fields once, as a walk in its own namespace (found by
// argument-dependent lookup):
//
//   template <class F> void fields(P& p, F&& f) {
//     f("k_fluvial", p.k_fluvial, Range{0, 1});  // numbers: with their range
//     f("enabled", p.enabled);                   // bools: no range
//     f("norm", p.norm, OneOf{{"batch", "none"}});  // enums as strings
//     f("erosion", p.erosion);                   // a nested params struct
//   }
//
// and that one walk serves serialisation, the key list, strict parsing
// (unknown keys, types, whole numbers, ranges, each error naming the file
// and the key) and the tests' round trip, so a field cannot be forgotten in
// one of them. Defaults and units live in the struct's member initialisers
// and their one-line comments.
#include <algorithm>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "reefgen/io.hpp"
#include "reefgen/json_read.hpp"

namespace reefgen {

// A numeric range: [lo, hi], or open at either end.
struct Range {
  double lo, hi;
  bool open_lo = false, open_hi = false;
};
// The values a string field (an enum kept readable in JSON) may take.
struct OneOf {
  std::vector<std::string> values;
};

namespace params_detail {
struct AnyField {
  template <class... A>
  void operator()(const char*, A&&...) const {}
};
template <class T, class = void>
struct has_fields : std::false_type {};
template <class T>
struct has_fields<T, std::void_t<decltype(fields(std::declval<T&>(), AnyField{}))>> : std::true_type {};

// "ORIGIN: " in front of a message, or nothing for a caller that adds the
// file's name itself.
inline std::string at(const std::string& origin) { return origin.empty() ? std::string() : origin + ": "; }

inline std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
}  // namespace params_detail

// True for a struct that declares a field walk.
template <class T>
inline constexpr bool has_fields_v = params_detail::has_fields<T>::value;

// Every field inside its range or list (nested structs too); throws
// reefgen::Error "ORIGIN: PREFIXkey = value is out of range; expected [lo, hi]
// (see SEE)" or "...; use a, b or c". For params set by flags as well as files.
template <class P>
void check_params(const P& params, const std::string& origin, const std::string& see, const std::string& prefix = "") {
  P p = params;
  fields(p, [&](const char* k, const auto& v, auto... constraint) {
    using T = std::decay_t<decltype(v)>;
    const std::string where = params_detail::at(origin) + prefix + k;
    if constexpr (has_fields_v<T>) {
      check_params(v, origin, see, prefix + k + ".");
    } else if constexpr (sizeof...(constraint) == 1) {
      const auto c = (constraint, ...);
      if constexpr (std::is_same_v<decltype(c), const Range>) {
        const double d = double(v);
        const bool ok = d == d && (c.open_lo ? d > c.lo : d >= c.lo) && (c.open_hi ? d < c.hi : d <= c.hi);
        if (!ok)
          throw Error(where + " = " + params_detail::num(d) + " is out of range; expected " + (c.open_lo ? "(" : "[") +
                      params_detail::num(c.lo) + ", " + params_detail::num(c.hi) + (c.open_hi ? ")" : "]") + " (see " +
                      see + ")");
      } else {
        if (std::find(c.values.begin(), c.values.end(), v) == c.values.end()) {
          std::string list;
          for (size_t i = 0; i < c.values.size(); ++i)
            list += (i == 0 ? "" : i + 1 == c.values.size() ? " or " : ", ") + c.values[i];
          throw Error(where + " = '" + v + "'; use " + list);
        }
      }
    }
  });
}

template <class P>
nlohmann::json params_json(const P& params) {
  P p = params;
  nlohmann::json j = nlohmann::json::object();
  fields(p, [&](const char* k, const auto& v, auto...) {
    using T = std::decay_t<decltype(v)>;
    if constexpr (has_fields_v<T>)
      j[k] = params_json(v);
    else
      j[k] = v;
  });
  return j;
}

// Strict parse: the struct's keys only (and `ignored`, e.g. "description"),
// each typed as its field, numbers inside their range; every key optional
// (defaults stay). Errors name `origin` (none when empty), prefix + the key,
// and `see`.
template <class P>
P params_from_json(const nlohmann::json& j, const std::string& origin, const std::string& see,
                   const std::string& prefix = "", const std::vector<std::string>& ignored = {}) {
  if (!j.is_object())
    throw Error(params_detail::at(origin) + (prefix.empty() ? std::string("params") : prefix.substr(0, prefix.size() - 1)) +
                " must be a JSON object (see " + see + ")");
  P p;
  std::vector<std::string> keys = ignored;
  fields(p, [&](const char* k, const auto&, auto...) { keys.emplace_back(k); });
  for (const auto& [k, v] : j.items())
    if (std::find(keys.begin(), keys.end(), k) == keys.end())
      throw Error(params_detail::at(origin) + "unknown key \"" + prefix + k + "\" (see " + see + ")");
  fields(p, [&](const char* k, auto& v, auto...) {
    if (!j.contains(k)) return;
    using T = std::decay_t<decltype(v)>;
    if constexpr (has_fields_v<T>)
      v = params_from_json<T>(j.at(k), origin, see, prefix + k + ".");
    else
      read_json_value(j.at(k), v, params_detail::at(origin) + prefix + k);
  });
  check_params(p, origin, see, prefix);
  return p;
}

}  // namespace reefgen
