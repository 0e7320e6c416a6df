#pragma once
// build_dataset's writers for the layouts other tools read (formats.hpp,
// docs/DATASET.md "Layouts for other tools"). Private to augment/.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "reefgen/augment/build.hpp"
#include "reefgen/augment/dataset.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/parallel.hpp"

namespace reefgen::augment::layouts {

// Heights are normalised for training by this fixed range (docs/DESIGN.md §5:
// "a fixed range stored with the model"); dataset.json records it and the
// pix2pix layout's 16 bits span it. It bounds every generated height: M(0) =
// -100 m (coral keeps the floor there) up to M(1) = 500 m × (1 + detail noise
// 0.1) + smooth-max overshoot ≤ 1 m.
inline constexpr double kNormFloorM = kAbyssFloorM, kNormPeakM = kHeightCeilingM;

// The fields every layout's manifest line and sample record start with.
nlohmann::json pair_record(const PairInfo& info, const Pair& pair);

// One pair's files in a per-pair layout (pix2pix, imagefolder): its manifest
// line and, for imagefolder, its line of SPLIT/metadata.jsonl. `reused`: the
// files were there from an interrupted build, verified byte for byte.
struct PairFiles {
  nlohmann::json record;
  std::string metadata_line;
  bool reused = false;
};
PairFiles write_pair(DatasetLayout layout, const std::filesystem::path& dir, const std::string& stem,
                     const PairInfo& info, const Pair& pair);

// What dataset.json says of the files of a layout other than reefgen's.
nlohmann::json layout_description(DatasetLayout layout, int size_px);

// The WebDataset layout: SPLIT-NNNNNN.tar shards of a fixed number of pairs
// (as many as fit in tar_mb), SPLIT.index.json (wids' shard index) and
// manifest.jsonl (in shard order, member checksums). A shard finished by an
// interrupted build is verified against the bytes it must hold, not rewritten.
BuildResult build_webdataset(const DatasetParams& p, const BuildOptions& a, Progress& progress);

}  // namespace reefgen::augment::layouts
