#pragma once
// Writing a generated island with the file conventions of docs/DESIGN.md §2:
//   PREFIX.height.exr  float32, channel Y, metres, sea level 0, metadata attributes
//   PREFIX.label.png   8-bit RGB HSV labels
//   PREFIX.preview.png hypsometric, hill-shaded preview (optional)
//   PREFIX.flow.png, .slope.png, … the layers of terrain/layers.hpp (optional)
//   PREFIX.json        sidecar, written last: its presence marks a complete island
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "reefgen/files.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/terrain/layers.hpp"

namespace reefgen::procgen {

struct WrittenIsland {
  std::vector<std::filesystem::path> files;  // in the order written, sidecar last
  nlohmann::json sidecar;
};

// More files of the same island staged with it (all or nothing), e.g. the
// GeoTIFFs: given the staging, the sidecar to extend and the layers (or null).
using ExtraFiles = std::function<void(StagedOutputs&, nlohmann::json& sidecar, const terrain::Layers* layers)>;

// `height_path` replaces PREFIX.height.exr when given (`-o NAME.exr`).
// `layers`: the layers with these rules (fields.uneroded_m gives wear and
// deposit; render with keep_uneroded), computed on `threads` threads (same
// bytes whatever the count) and given to `extra`; their own files too
// unless `layer_files` is false (an engine bundle wants only the layers).
WrittenIsland write_island(const std::filesystem::path& prefix, const IslandFields& fields, const IslandSpec& spec,
                           const nlohmann::json& provenance, bool preview,
                           const std::filesystem::path& height_path = {},
                           const terrain::LayerParams* layers = nullptr, int threads = 1,
                           const ExtraFiles& extra = {}, bool layer_files = true);

// The paper's data generation (`generate --random`): `count` random specs,
// each at `levels` subsidence levels, written as DIR/island_IIIIII_lL.*.
struct RandomIslands {
  int count = 1;             // random specs, [1, 1e7]
  int levels = 4;            // subsidence levels per spec, evenly spaced on [0, 1], [1, 64]
  uint64_t seed = 0;         // random_spec(seed, index)
  RenderOptions render;      // size and warp grid of every island
  bool preview = false;      // also PREFIX.preview.png
  bool layers = false;       // also the layer files (terrain/layers.hpp) with layer_params
  terrain::LayerParams layer_params;
  int threads = 1;           // workers, [1, 256]; the files are the same whatever the count
};
struct RandomIslandsResult {
  size_t total = 0, skipped = 0;  // islands asked for; already complete in DIR (a resumed run)
};
// Resumable: an island whose sidecar and files are all there is skipped; a
// sidecar made with other settings (seed, index, size, level) throws
// reefgen::Error naming it. progress(done) is called as islands finish.
RandomIslandsResult write_random_islands(const std::filesystem::path& dir, const RandomIslands& r,
                                         const std::function<void(size_t)>& progress = {});

}  // namespace reefgen::procgen
