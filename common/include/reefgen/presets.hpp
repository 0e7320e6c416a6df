#pragma once
// Built-in presets (configs/*/NAME.json compiled in, cli/CMakeLists.txt's
// embed_json_configs): one look-up for every command and the Python module.
#include <map>
#include <string>

#include "reefgen/error.hpp"

namespace reefgen {

// The JSON text of preset `name`, or an Error naming the choices:
// unknown <what> "x"; use one of a, b, c.
inline const std::string& preset_text(const std::map<std::string, std::string>& presets, const std::string& name,
                                      const std::string& what = "preset") {
  const auto it = presets.find(name);
  if (it != presets.end()) return it->second;
  std::string names;
  for (const auto& [k, v] : presets) names += (names.empty() ? "" : ", ") + k;
  throw Error("unknown " + what + " \"" + name + "\"; use one of " + names);
}

}  // namespace reefgen
