#pragma once
// Reading one JSON value into a typed field without silent coercion:
// nlohmann's get<> turns -1 into 18446744073709551615 for an unsigned field,
// 2.7 into 2 and 1e30 into garbage for an integer one. Here an integer field
// takes only a whole number inside its type's range, and the error names the
// field (`where`, e.g. "spec.json: noise.seed") and the value.
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "reefgen/files.hpp"

namespace reefgen {

template <class T>
void read_json_value(const nlohmann::json& v, T& out, const std::string& where) {
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
    using L = std::numeric_limits<T>;
    auto refuse = [&](const std::string& why) {
      std::ostringstream s;
      s << where << " = " << v.dump() << " " << why;
      throw Error(s.str());
    };
    if (!v.is_number()) refuse("must be a whole number");
    if (v.is_number_float()) {
      const double d = v.get<double>();
      if (!std::isfinite(d) || d != std::floor(d)) refuse("must be a whole number");
      // 2^digits is the first value past the type (double(L::max()) rounds
      // up to it for 64-bit types: a seed of 2^64 passed and became 0).
      if (d < double(L::min()) || d >= std::ldexp(1.0, L::digits))
        refuse("is out of range; expected " + std::to_string(L::min()) + ".." + std::to_string(L::max()));
      out = T(d);
    } else if (v.is_number_unsigned()) {
      const uint64_t u = v.get<uint64_t>();
      if (u > uint64_t(L::max())) refuse("is out of range; expected ≤ " + std::to_string(L::max()));
      out = T(u);
    } else {
      const int64_t i = v.get<int64_t>();
      if (i < 0 && !L::is_signed) refuse("must not be negative");
      if ((L::is_signed && i < int64_t(L::min())) || (i > 0 && uint64_t(i) > uint64_t(L::max())))
        refuse("is out of range; expected " + std::to_string(L::min()) + ".." + std::to_string(L::max()));
      out = T(i);
    }
  } else {
    // nlohmann's own message ("type_error.302: type must be number, but is
    // string") names neither the field nor the value.
    const char* want = std::is_same_v<T, bool>                                    ? "must be true or false"
                       : std::is_floating_point_v<T>                              ? "must be a number"
                       : std::is_same_v<T, std::string>                           ? "must be a string"
                                                                                  : "has the wrong type";
    if constexpr (std::is_floating_point_v<T>) {
      if (!v.is_number()) throw Error(where + " = " + v.dump() + " " + want);
    } else if constexpr (std::is_same_v<T, bool>) {
      if (!v.is_boolean()) throw Error(where + " = " + v.dump() + " " + want);
    } else if constexpr (std::is_same_v<T, std::string>) {
      if (!v.is_string()) throw Error(where + " = " + v.dump() + " " + want);
    }
    try {
      v.get_to(out);
    } catch (const nlohmann::json::exception&) {
      throw Error(where + " = " + v.dump().substr(0, 80) + " " + want);
    }
  }
}

}  // namespace reefgen
