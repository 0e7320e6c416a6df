#pragma once
// Writing a generated island with the file conventions of docs/DESIGN.md §2:
//   PREFIX.height.exr  float32, channel Y, metres, sea level 0, metadata attributes
//   PREFIX.label.png   8-bit RGB HSV labels
//   PREFIX.preview.png hypsometric, hill-shaded preview (optional)
//   PREFIX.json        sidecar, written last: its presence marks a complete island
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "reefgen/procgen/generator.hpp"

namespace reefgen::procgen {

struct WrittenIsland {
  std::vector<std::filesystem::path> files;  // in the order written, sidecar last
  nlohmann::json sidecar;
};

// `height_path` replaces PREFIX.height.exr when given (`-o NAME.exr`).
WrittenIsland write_island(const std::filesystem::path& prefix, const IslandFields& fields, const IslandSpec& spec,
                           const nlohmann::json& provenance, bool preview,
                           const std::filesystem::path& height_path = {});

}  // namespace reefgen::procgen
