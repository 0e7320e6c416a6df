#pragma once
// `reefgen bench realism` as a library: the realism statistics
// (docs/REALISM.md) of random specs generated at size_px and of painted
// sketches answered by `infer --size size_px`, their medians and whether they
// meet the realism bars (pits ≤ 1 %, terraces ≤ 3 %, valleys ≥ 0.30), and the
// time per island.
#include <cstdint>
#include <filesystem>
#include <vector>

#include <nlohmann/json.hpp>

#include "reefgen/infer/infer.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/terrain/realism.hpp"

namespace reefgen::bench {

struct RealismBenchOptions {
  int specs = 50;                 // random specs generated directly (0 = none), [0, 10000]
  int size_px = 1025;             // side of every island, [64, 8192]
  uint64_t spec_seed = 1;         // seed of the random specs
  double subsidence = 0;          // λ of every random spec, [0, 1] (0: young islands, the most flank to judge)
  infer::InferOptions infer;             // the painted sketches' inference (its size_px is set to size_px)
  bool quiet = false;             // no progress lines on stderr
};

// {"specs": {...}} when o.specs > 0 and {"painted": {..., "per_sketch": {...}}}
// when `painted` is not empty (then `g` must be given): count, no_flank,
// median_pits, median_terraces, median_valleys, min_valleys, median_ms,
// bars_met (realism_summary's).
nlohmann::json realism_bench(const RealismBenchOptions& o, model::GeneratorFile* g,
                             const std::vector<std::filesystem::path>& painted);

// The medians of a set's statistics and whether they meet the bars. Terraces
// and valleys are shares of the flank: a canvas with none (flank_cells 0, a
// painted atoll whose rim is under water) is left out of their medians and
// counted in no_flank, not counted as a canvas without valleys.
nlohmann::json realism_summary(const std::vector<terrain::RealismStats>& s, const std::vector<double>& ms);

}  // namespace reefgen::bench
