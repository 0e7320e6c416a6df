// reefgen bench realism: issue 20's realism bars, measured the way
// docs/REALISM.md defines them — N random specs generated at --size, and the
// painted sketches of tests/data/painted answered by `infer --size`; medians
// of pits, terraces and valleys with the bars, and the time per island. One
// JSON object on stdout (CPU model included: figures depend on it).
#include <algorithm>
#include <cstdio>
#include <fstream>

#include <nlohmann/json.hpp>

#include "app.hpp"
#include "reefgen/infer/infer.hpp"
#include "reefgen/io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/random_spec.hpp"
#include "reefgen/terrain.hpp"

namespace reefgen {

namespace {

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}

// Medians of a set's statistics and whether they meet the bars
// (pits ≤ 1 %, terraces ≤ 3 %, valleys ≥ 0.30).
nlohmann::json summary(const std::vector<RealismStats>& s, const std::vector<double>& ms) {
  std::vector<double> pits, terraces, valleys;
  for (const auto& r : s) {
    pits.push_back(r.pits);
    terraces.push_back(r.terraces);
    valleys.push_back(r.valleys);
  }
  const double p = median(pits), t = median(terraces), v = median(valleys);
  return {{"count", s.size()},
          {"median_pits", p},
          {"median_terraces", t},
          {"median_valleys", v},
          {"min_valleys", valleys.empty() ? 0.0 : *std::min_element(valleys.begin(), valleys.end())},
          {"median_ms", median(ms)},
          {"bars_met", p <= 0.01 && t <= 0.03 && v >= 0.30}};
}

}  // namespace

std::function<int()> add_bench_realism_command(CLI::App* bench, const GlobalOptions& g, CLI::App** sub_out) {
  struct Args {
    int specs = 50, size = 1025;
    uint64_t seed = 1, painted_seed = 0;
    double subsidence = 0;
    std::string model, painted = "tests/data/painted", erosion;
  };
  auto a = std::make_shared<Args>();
  auto* sub = bench->add_subcommand(
      "realism", "Realism bars (docs/REALISM.md): medians over random specs and painted sketches at --size\n\n"
                 "Examples:\n"
                 "  reefgen bench realism                          # 50 specs + tests/data/painted at 1025²\n"
                 "  reefgen bench realism --specs 8 --size 513 --painted ''\n"
                 "  reefgen bench realism --specs 0 --painted-seed 3  # the painted set, another amplification noise\n");
  *sub_out = sub;
  sub->add_option("--specs", a->specs, "Random specs (0 = none)")->capture_default_str()->check(CLI::Range(0, 10000));
  sub->add_option("--size", a->size, "Side of each island, pixels")->capture_default_str()->check(CLI::Range(64, 8192));
  sub->add_option("--seed", a->seed, "Seed of the random specs")->capture_default_str()->check(seed_value());
  sub->add_option("--subsidence", a->subsidence,
                  "λ of every random spec (0 = young islands: the most flank to judge)")
      ->capture_default_str()
      ->check(finite_in(0, 1));
  sub->add_option("-m,--model", a->model, "Generator for the painted sketches (default: the shipped model)");
  sub->add_option("--painted", a->painted, "Folder of painted sketches ('' = none)")->capture_default_str();
  sub->add_option("--erosion", a->erosion, "JSON of the painted sketches' amplification params (as infer --erosion)");
  sub->add_option("--painted-seed", a->painted_seed,
                  "Seed of the painted sketches' amplification noise (as infer --seed): the spread over a few "
                  "seeds is the figure's noise")
      ->capture_default_str()
      ->check(seed_value());
  return [a, &g]() -> int {
    nlohmann::json out = {{"bench", "realism"}, {"size", a->size}, {"cpu", cpu_model()}};
    if (a->specs > 0) {
      std::vector<RealismStats> stats;
      std::vector<double> ms;
      procgen::RenderOptions ro;
      ro.size_px = a->size;
      Progress progress("realism specs", size_t(a->specs), g.quiet);
      for (int i = 0; i < a->specs; ++i) {
        procgen::IslandSpec spec = procgen::random_spec(a->seed, uint64_t(i));
        spec.subsidence = a->subsidence;
        procgen::IslandFields f;
        ms.push_back(1e3 * seconds_of([&] { f = procgen::generate(spec, ro); }));
        stats.push_back(realism_stats(f.height_m, spec.world_size_m / a->size));
        progress.tick(size_t(i + 1));
      }
      out["specs"] = summary(stats, ms);
      out["specs"]["seed"] = a->seed;
      out["specs"]["subsidence"] = a->subsidence;
    }
    if (!a->painted.empty()) {
      if (!fs::is_directory(a->painted)) throw Error(a->painted + ": no such folder of painted sketches (or --painted '')");
      const std::vector<fs::path> files = images_in(a->painted);
      if (files.empty()) throw Error(a->painted + ": no sketch images in it");
      const fs::path model_path = model::resolve_model_path(a->model);
      model::GeneratorFile gen = model::load_generator(model_path);
      infer::InferOptions io;
      io.size_px = a->size;
      io.seed = a->painted_seed;
      if (!a->erosion.empty()) io.erosion = procgen::erosion_params_from_json(read_json(a->erosion), a->erosion);
      std::vector<RealismStats> stats;
      std::vector<double> ms;
      nlohmann::json per = nlohmann::json::object();
      Progress progress("realism painted", files.size(), g.quiet);
      for (size_t i = 0; i < files.size(); ++i) {
        const DecodedSketch s = read_sketch(files[i]);
        cv::Mat1f h;
        ms.push_back(1e3 * seconds_of([&] { h = infer::infer_heights(gen, {s}, io)[0]; }));
        stats.push_back(realism_stats(h, io.world_size_m / a->size));
        per[files[i].filename().string()] = {{"pits", stats.back().pits},
                                             {"terraces", stats.back().terraces},
                                             {"valleys", stats.back().valleys}};
        progress.tick(i + 1);
      }
      out["painted"] = summary(stats, ms);
      out["painted"]["model"] = model_path.string();
      out["painted"]["seed"] = a->painted_seed;
      out["painted"]["per_sketch"] = per;
    }
    std::printf("%s\n", out.dump(1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
    return 0;
  };
}

}  // namespace reefgen
