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
//     f("profile", p.profile, Range{0, 1}, Count{2, 4096});  // a list of numbers
//     f("wind", p.wind, Count{0, 64});           // a list of params structs
//     f("outlines", p.outlines, Custom<O>{write, read, check});  // a form of its own
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

#include "reefgen/files.hpp"
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
// How many elements a list field (std::vector) may hold.
struct Count {
  size_t lo, hi;
};
// A field whose JSON form is its own (e.g. "a radius or an array of radii",
// points as [x, y]): how to write, read and check it. read and check throw
// reefgen::Error starting with `where` (the origin and the key).
template <class T>
struct Custom {
  nlohmann::json (*write)(const T&);
  void (*read)(const nlohmann::json&, T&, const std::string& where);
  void (*check)(const T&, const std::string& where);
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
template <class T>
struct is_vector : std::false_type {};
template <class T, class A>
struct is_vector<std::vector<T, A>> : std::true_type {};
// A list of params structs (each with its own walk).
template <class T>
struct is_walk_list : std::false_type {};
template <class T, class A>
struct is_walk_list<std::vector<T, A>> : has_fields<T> {};
template <class T>
struct is_custom : std::false_type {};
template <class T>
struct is_custom<Custom<T>> : std::true_type {};

// "ORIGIN: " in front of a message, or nothing for a caller that adds the
// file's name itself.
inline std::string at(const std::string& origin) { return origin.empty() ? std::string() : origin + ": "; }

inline std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

inline void check_range(double d, const Range& c, const std::string& where, const std::string& see) {
  const bool ok = d == d && (c.open_lo ? d > c.lo : d >= c.lo) && (c.open_hi ? d < c.hi : d <= c.hi);
  if (!ok)
    throw Error(where + " = " + num(d) + " is out of range; expected " + (c.open_lo ? "(" : "[") + num(c.lo) + ", " +
                num(c.hi) + (c.open_hi ? ")" : "]") + " (see " + see + ")");
}

// The field's custom form, if it declares one.
template <class... C>
constexpr bool any_custom() {
  return (is_custom<std::decay_t<C>>::value || ...);
}
template <class T, class C, class... Rest>
const Custom<T>& custom_of(const C& c, const Rest&... rest) {
  if constexpr (is_custom<C>::value)
    return c;
  else
    return custom_of<T>(rest...);
}
template <class V, class C>
void check_count(const V& v, const C& c, const std::string& where, const std::string& see) {
  if (v.size() < c.lo || v.size() > c.hi)
    throw Error(where + " has " + std::to_string(v.size()) + (v.size() == 1 ? " element" : " elements") +
                "; expected " + std::to_string(c.lo) + ".." + std::to_string(c.hi) + " (see " + see + ")");
}

// A number, or each element of a list of numbers.
template <class V, class C>
void check_range_field(const V& v, const C& c, const std::string& where, const std::string& see) {
  if constexpr (is_vector<V>::value) {
    for (size_t i = 0; i < v.size(); ++i) check_range(double(v[i]), c, where + "[" + std::to_string(i) + "]", see);
  } else {
    check_range(double(v), c, where, see);
  }
}

template <class V, class C>
void check_one_of(const V& v, const C& c, const std::string& where) {
  if (std::find(c.values.begin(), c.values.end(), v) == c.values.end()) {
    std::string list;
    for (size_t i = 0; i < c.values.size(); ++i)
      list += (i == 0 ? "" : i + 1 == c.values.size() ? " or " : ", ") + c.values[i];
    throw Error(where + " = '" + v + "'; use " + list);
  }
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
  fields(p, [&](const char* k, const auto& v, const auto&... constraint) {
    using T = std::decay_t<decltype(v)>;
    const std::string where = params_detail::at(origin) + prefix + k;
    if constexpr (params_detail::any_custom<decltype(constraint)...>()) {
      params_detail::custom_of<T>(constraint...).check(v, where);
    } else if constexpr (has_fields_v<T>) {
      check_params(v, origin, see, prefix + k + ".");
    } else {
      auto apply = [&](const auto& c) {
        using C = std::decay_t<decltype(c)>;
        // The checks are calls that take c, so they stay
        // dependent here: clang checks the non-dependent expressions of a
        // nested generic lambda eagerly (v.size() on a double).
        if constexpr (std::is_same_v<C, Count>) {
          params_detail::check_count(v, c, where, see);
        } else if constexpr (std::is_same_v<C, Range>) {
          params_detail::check_range_field(v, c, where, see);
        } else if constexpr (std::is_same_v<C, OneOf>) {
          params_detail::check_one_of(v, c, where);
        }
      };
      (apply(constraint), ...);
      if constexpr (params_detail::is_walk_list<T>::value)
        for (size_t i = 0; i < v.size(); ++i) check_params(v[i], origin, see, prefix + k + "[" + std::to_string(i) + "].");
    }
  });
}

template <class P>
nlohmann::json params_json(const P& params) {
  P p = params;
  nlohmann::json j = nlohmann::json::object();
  fields(p, [&](const char* k, const auto& v, const auto&... constraint) {
    using T = std::decay_t<decltype(v)>;
    if constexpr (params_detail::any_custom<decltype(constraint)...>()) {
      j[k] = params_detail::custom_of<T>(constraint...).write(v);
    } else if constexpr (has_fields_v<T>) {
      j[k] = params_json(v);
    } else if constexpr (params_detail::is_walk_list<T>::value) {
      j[k] = nlohmann::json::array();
      for (const auto& e : v) j[k].push_back(params_json(e));
    } else {
      j[k] = v;
    }
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
  fields(p, [&](const char* k, auto& v, const auto&... constraint) {
    if (!j.contains(k)) return;
    using T = std::decay_t<decltype(v)>;
    const nlohmann::json& x = j.at(k);
    const std::string where = params_detail::at(origin) + prefix + k;
    if constexpr (params_detail::any_custom<decltype(constraint)...>()) {
      params_detail::custom_of<T>(constraint...).read(x, v, where);
    } else if constexpr (has_fields_v<T>) {
      v = params_from_json<T>(x, origin, see, prefix + k + ".");
    } else if constexpr (params_detail::is_walk_list<T>::value) {
      using E = typename T::value_type;
      if (!x.is_array()) throw Error(where + " must be an array (see " + see + ")");
      v.clear();
      for (size_t i = 0; i < x.size(); ++i)
        v.push_back(params_from_json<E>(x[i], origin, see, prefix + k + "[" + std::to_string(i) + "]."));
    } else {
      // A whole number far outside its field's range (1e30 for [1, 100]) is
      // reported against that range, not against the integer type's.
      if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
        auto range_first = [&](const auto& c) {
          if constexpr (std::is_same_v<std::decay_t<decltype(c)>, Range>)
            if (x.is_number()) params_detail::check_range(x.get<double>(), c, where, see);
        };
        (range_first(constraint), ...);
      }
      read_json_value(x, v, where);
    }
  });
  check_params(p, origin, see, prefix);
  return p;
}

}  // namespace reefgen
