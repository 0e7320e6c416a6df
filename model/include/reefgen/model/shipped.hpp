#pragma once
// The model that ships with reefgen (models/, docs/MODEL.md): what `infer`,
// `eval-sketches` and the studio use when no -m is given.
#include <filesystem>
#include <string>

namespace reefgen::model {

inline constexpr const char* kShippedModelFile = "reef-256.pt";

// The generator to load: `flag` if given; else $REEFGEN_MODEL; else the
// shipped model next to the executable's source tree (models/reef-256.pt).
// Throws reefgen-style std::runtime_error naming what to do when none exists.
std::filesystem::path resolve_model_path(const std::string& flag);

}  // namespace reefgen::model
