// reefgen bench dataset: pairs per second of `dataset build` (the bar:
// ≥ 100 pairs/s at 256² on 2 cores with the fluvial erosion). Each run builds
// into a fresh folder under the system's temporary directory and removes it;
// one JSON object on stdout with every run, their median and the CPU model.
#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "app.hpp"
#include "reefgen/augment/build.hpp"
#include "reefgen/files.hpp"
#include "reefgen/parallel.hpp"

namespace reefgen {

std::function<int()> add_bench_dataset_command(CLI::App* bench, const GlobalOptions& g, CLI::App** sub_out) {
  struct Args {
    std::string config;
    int count = 300, reps = 5, threads = default_threads();
    uint64_t seed = 5;
  };
  auto a = std::make_shared<Args>();
  auto* sub = bench->add_subcommand(
      "dataset", "pairs/s of `dataset build` (median of --reps builds into a temporary folder)\n\n"
                 "Examples:\n"
                 "  reefgen bench dataset                                   # erosion on every curve island, 300 pairs\n"
                 "  reefgen bench dataset --config configs/dataset/shipped.json --reps 7\n");
  *sub_out = sub;
  sub->add_option("--config", a->config,
                  "Dataset config JSON (default: the built-in defaults with p_erosion 1, erosion on every curve island)");
  sub->add_option("--count", a->count, "Pairs per build")->capture_default_str()->check(CLI::Range(1, 1000000));
  sub->add_option("--reps", a->reps, "Builds (median)")->capture_default_str()->check(CLI::Range(1, 1000));
  sub->add_option("--seed", a->seed, "Global seed")->capture_default_str()->check(seed_value());
  sub->add_option("--threads", a->threads, "Worker threads (default: all cores)")->check(CLI::Range(1, 256));
  return [a, &g]() -> int {
    augment::DatasetParams p;
    p.p_erosion = 1;
    if (!a->config.empty()) {
      if (!fs::exists(a->config)) throw Error("cannot read " + a->config + ": no such file");
      p = augment::dataset_params_from_json(read_json(a->config), a->config);
    }
    p.count = a->count;
    std::vector<double> rates;
    for (int r = 0; r < a->reps; ++r) {
      augment::BuildOptions o;
      o.out = fs::temp_directory_path() /
              ("reefgen-bench-dataset-" + std::to_string(::getpid()) + "-" + std::to_string(r));
      o.seed = a->seed;
      o.threads = a->threads;
      o.quiet = true;
      fs::remove_all(o.out);
      double s = 0;
      try {
        s = seconds_of([&] { (void)augment::build_dataset(p, o); });
      } catch (...) {
        fs::remove_all(o.out);
        throw;
      }
      fs::remove_all(o.out);
      rates.push_back(a->count / s);
      if (!g.quiet) std::fprintf(stderr, "bench dataset: run %d/%d: %.1f pairs/s\n", r + 1, a->reps, rates.back());
    }
    const nlohmann::json out = {{"bench", "dataset"},
                                {"config", a->config.empty() ? "defaults + p_erosion 1" : a->config},
                                {"size_px", p.size_px},
                                {"p_erosion", p.p_erosion},
                                {"count", a->count},
                                {"threads", a->threads},
                                {"pairs_per_s", rates},
                                {"median_pairs_per_s", median(rates)},
                                {"cpu", cpu_model()}};
    std::printf("%s\n", out.dump().c_str());
    return 0;
  };
}

}  // namespace reefgen
