#include "reefgen/bench/realism_bench.hpp"

#include <algorithm>
#include <chrono>

#include "reefgen/files.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/parallel.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/random_spec.hpp"
#include "reefgen/stats.hpp"
#include "reefgen/terrain/realism.hpp"

namespace reefgen::bench {

using terrain::realism_stats;
using terrain::RealismStats;

namespace {

template <class F>
double ms_of(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

nlohmann::json realism_summary(const std::vector<RealismStats>& s, const std::vector<double>& ms) {
  std::vector<double> pits, terraces, valleys;
  int no_flank = 0;
  for (const auto& r : s) {
    pits.push_back(r.pits);
    if (r.flank_cells == 0) {
      ++no_flank;
      continue;
    }
    terraces.push_back(r.terraces);
    valleys.push_back(r.valleys);
  }
  const double p = median(pits), t = median(terraces), v = median(valleys);
  return {{"count", s.size()},
          {"no_flank", no_flank},
          {"median_pits", p},
          {"median_terraces", t},
          {"median_valleys", v},
          {"min_valleys", valleys.empty() ? 0.0 : *std::min_element(valleys.begin(), valleys.end())},
          {"median_ms", median(ms)},
          {"bars_met", p <= 0.01 && t <= 0.03 && v >= 0.30}};
}

nlohmann::json realism_bench(const RealismBenchOptions& o, model::GeneratorFile* g,
                             const std::vector<std::filesystem::path>& painted) {
  if (o.specs < 0 || o.specs > 10000) throw Error("realism bench: specs must be in 0..10000");
  if (o.size_px < 64 || o.size_px > 8192) throw Error("realism bench: size must be in 64..8192");
  if (!(o.subsidence >= 0 && o.subsidence <= 1)) throw Error("realism bench: subsidence must be in [0, 1]");
  nlohmann::json out = nlohmann::json::object();
  if (o.specs > 0) {
    std::vector<RealismStats> stats;
    std::vector<double> ms;
    procgen::RenderOptions ro;
    ro.size_px = o.size_px;
    Progress progress("realism specs", size_t(o.specs), o.quiet);
    for (int i = 0; i < o.specs; ++i) {
      procgen::IslandSpec spec = procgen::random_spec(o.spec_seed, uint64_t(i));
      spec.subsidence = o.subsidence;
      procgen::IslandFields f;
      ms.push_back(ms_of([&] { f = procgen::generate(spec, ro); }));
      stats.push_back(realism_stats(f.height_m, spec.world_size_m / o.size_px));
      progress.tick(size_t(i + 1));
    }
    out["specs"] = realism_summary(stats, ms);
    out["specs"]["seed"] = o.spec_seed;
    out["specs"]["subsidence"] = o.subsidence;
  }
  if (!painted.empty()) {
    if (g == nullptr) throw Error("realism bench: painted sketches need a generator");
    infer::InferOptions io = o.infer;
    io.size_px = o.size_px;
    std::vector<RealismStats> stats;
    std::vector<double> ms;
    nlohmann::json per = nlohmann::json::object();
    Progress progress("realism painted", painted.size(), o.quiet);
    for (size_t i = 0; i < painted.size(); ++i) {
      const DecodedSketch s = read_sketch(painted[i]);
      cv::Mat1f h;
      ms.push_back(ms_of([&] { h = infer::infer_heights(*g, {s}, io)[0]; }));
      stats.push_back(realism_stats(h, io.world_size_m / o.size_px));
      const RealismStats& st = stats.back();
      const bool flank = st.flank_cells > 0;
      // Without a flank terraces and valleys are not judged (null).
      nlohmann::json& one = per[painted[i].filename().string()] = st;
      if (!flank) one["terraces"] = one["valleys"] = nullptr;
      progress.tick(i + 1);
    }
    out["painted"] = realism_summary(stats, ms);
    out["painted"]["seed"] = io.seed;
    out["painted"]["variation"] = io.variation;
    out["painted"]["per_sketch"] = per;
  }
  return out;
}

}  // namespace reefgen::bench
