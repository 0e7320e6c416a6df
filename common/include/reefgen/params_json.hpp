#pragma once
// reefgen's one params mechanism (docs/DESIGN.md §2): a params struct P
// declares its fields once, as a walk in its own namespace (found by
// argument-dependent lookup):
//
//   template <class F> void fields(P& p, F&& f) {
//     f("k_fluvial", p.k_fluvial, Range{0, 1});  // numbers: with their range
//     f("enabled", p.enabled);                   // bools, strings: no range
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

// A closed numeric range [lo, hi].
struct Range {
  double lo, hi;
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

inline std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
}  // namespace params_detail

// True for a struct that declares a field walk.
template <class T>
inline constexpr bool has_fields_v = params_detail::has_fields<T>::value;

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
// (defaults stay). Errors name `origin`, prefix + the key, and `see`.
template <class P>
P params_from_json(const nlohmann::json& j, const std::string& origin, const std::string& see,
                   const std::string& prefix = "", const std::vector<std::string>& ignored = {}) {
  if (!j.is_object())
    throw Error(origin + ": " + (prefix.empty() ? std::string("params") : prefix.substr(0, prefix.size() - 1)) +
                " must be a JSON object (see " + see + ")");
  P p;
  std::vector<std::string> keys = ignored;
  fields(p, [&](const char* k, const auto&, auto...) { keys.emplace_back(k); });
  for (const auto& [k, v] : j.items())
    if (std::find(keys.begin(), keys.end(), k) == keys.end())
      throw Error(origin + ": unknown key \"" + prefix + k + "\" (see " + see + ")");
  fields(p, [&](const char* k, auto& v, auto... range) {
    if (!j.contains(k)) return;
    using T = std::decay_t<decltype(v)>;
    if constexpr (has_fields_v<T>) {
      v = params_from_json<T>(j.at(k), origin, see, prefix + k + ".");
    } else {
      read_json_value(j.at(k), v, origin + ": " + prefix + k);
      if constexpr (sizeof...(range) == 1) {
        const Range r = (range, ...);
        if (!(double(v) >= r.lo && double(v) <= r.hi))
          throw Error(origin + ": " + prefix + k + " = " + j.at(k).dump() + " is out of range; expected [" +
                      params_detail::num(r.lo) + ", " + params_detail::num(r.hi) + "] (see " + see + ")");
      }
    }
  });
  return p;
}

}  // namespace reefgen
