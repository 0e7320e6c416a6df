#pragma once
// JSON for params structs that provide a field walk
//   static void fields(P& p, F&& f)  calling f("name", p.name) per field
// in the params struct's namespace (found by argument-dependent lookup). One walk
// serves serialisation, the key list and parsing, so a field cannot be
// forgotten in one of them.
#include <algorithm>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "reefgen/io.hpp"
#include "reefgen/json_read.hpp"

namespace reefgen {

template <class P>
nlohmann::json params_json(P p) {
  nlohmann::json j;
  fields(p, [&](const char* k, const auto& v) { j[k] = v; });
  return j;
}

// Strict parse: the struct's keys only, each typed as its field; every key
// optional (defaults stay). Errors name `origin`, the key and where to look.
template <class P>
P params_from_json(const nlohmann::json& j, const std::string& origin, const std::string& see) {
  if (!j.is_object()) throw Error(origin + ": params must be a JSON object (see " + see + ")");
  P p;
  std::vector<std::string> keys;
  fields(p, [&](const char* k, const auto&) { keys.emplace_back(k); });
  for (const auto& [k, v] : j.items())
    if (std::find(keys.begin(), keys.end(), k) == keys.end())
      throw Error(origin + ": unknown key \"" + k + "\" (see " + see + ")");
  std::string key;
  try {
    fields(p, [&](const char* k, auto& v) {
      key = k;
      if (j.contains(k)) read_json_value(j.at(k), v, origin + ": " + k);
    });
  } catch (const nlohmann::json::exception& e) {
    throw Error(origin + ": \"" + key + "\" has the wrong type of value (" + std::string(e.what()) + ")");
  }
  return p;
}

}  // namespace reefgen
