// reefgen bench generate: the speed figures of docs/BENCHMARKS.md.
// Prints one JSON object on stdout; medians of repeated runs because timings
// on a shared machine are noisy.
#include <algorithm>
#include <chrono>
#include <cstdio>

#include "app.hpp"
#include "reefgen/files.hpp"
#include "reefgen/islands/floating.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/random_spec.hpp"
#include "reefgen/islands/terrains.hpp"

namespace reefgen {

using namespace procgen;
using namespace islands;

namespace {

template <class F>
double time_ms(F&& f) {
  return 1e3 * seconds_of(std::forward<F>(f));
}


struct BenchGenerateArgs {
  int size = 256, reps = 50, strokes = 5, threads = default_threads(), islands = 400;
};

// The other island systems on one thread, medians of `reps`: Wilbur-style and
// mapgen4-style heights, and the floating island's closed mesh of a W² field's
// land (a Wilbur island as the top, its relief as H₀; segmentation excluded).
struct OtherGenerators {
  double wilbur_ms = 0, mapgen4_ms = 0, floating_ms = 0;
  size_t floating_triangles = 0;
};
OtherGenerators other_generators_ms(int size, int reps) {
  OtherGenerators o;
  std::vector<double> tw;
  WilburParams wp;
  wp.size_px = size;
  for (int r = 0; r < reps; ++r) tw.push_back(time_ms([&] { (void)wilbur_height(wp, uint64_t(r)); }));
  o.wilbur_ms = median(tw);
  tw.clear();
  Mapgen4Params mp;
  mp.size_px = size;
  for (int r = 0; r < reps; ++r) tw.push_back(time_ms([&] { (void)mapgen4_height(mp, uint64_t(r)); }));
  o.mapgen4_ms = median(tw);
  tw.clear();
  const cv::Mat1f land = cv::max(wilbur_height(wp, 1), 0.f);
  const cv::Mat1b top = (land > 0) / 255 * kPaintTop;
  FloatingParams fp;
  for (int r = 0; r < reps; ++r)
    tw.push_back(time_ms([&] { o.floating_triangles = floating_island(top, land, fp).mesh.triangles.size(); }));
  o.floating_ms = median(tw);
  return o;
}

// `bench generate`: ms per island on one thread (with and without detail
// noise and wind), islands/s on all cores, and the other island systems.
int run_bench_generate(const BenchGenerateArgs& a, bool quiet) {
  if (a.reps < 1 || a.islands < 1 || a.threads < 1) throw Error("--reps, --islands and --threads must be ≥ 1");
  RandomSpecParams rp;
  rp.strokes_min = rp.strokes_max = a.strokes;
  RenderOptions opt;
  opt.size_px = a.size;
  // Several different islands so that one lucky configuration does not decide the figure.
  std::vector<IslandSpec> specs;
  for (int i = 0; i < 8; ++i) specs.push_back(random_spec(12345, i, rp));
  auto single = [&](auto tweak) {
    std::vector<double> t;
    for (int r = 0; r < a.reps; ++r) {
      IslandSpec s = specs[r % specs.size()];
      s.subsidence = 0.5;
      tweak(s);
      t.push_back(time_ms([&] { (void)generate(s, opt); }));
    }
    return median(t);
  };
  single([](IslandSpec&) {});  // warm-up: page faults, caches
  const double full = single([](IslandSpec&) {});
  const double no_noise = single([](IslandSpec& s) { s.noise.amplitude = 0; });
  const double no_wind = single([](IslandSpec& s) { s.wind.clear(); });
  const OtherGenerators others = other_generators_ms(a.size, a.reps);
  Progress progress("bench", a.islands, quiet);
  const double wall = time_ms([&] {
    parallel_for(a.islands, a.threads, [&](size_t i) {
      IslandSpec s = specs[i % specs.size()];
      s.subsidence = 0.5;
      (void)generate(s, opt);
    }, [&](size_t d) { progress.tick(d); });
  });
  std::printf(
      "{\"bench\": \"generate\", \"size\": %d, \"strokes\": %d, \"reps\": %d,\n"
      " \"ms_per_island_1thread\": %.3f, \"ms_no_detail_noise\": %.3f, \"ms_no_wind\": %.3f,\n"
      " \"threads\": %d, \"islands_per_s\": %.1f, \"ms_wilbur_1thread\": %.3f, \"ms_mapgen4_1thread\": %.3f,\n"
      " \"ms_floating_mesh_1thread\": %.3f, \"floating_triangles\": %zu}\n",
      a.size, a.strokes, a.reps, full, no_noise, no_wind, a.threads, a.islands / (wall / 1000.0), others.wilbur_ms,
      others.mapgen4_ms, others.floating_ms, others.floating_triangles);
  return 0;
}

}  // namespace

Command add_bench_command(CLI::App& app, const GlobalOptions& g) {
  auto* sub = app.add_subcommand("bench", "Benchmarks (print figures; not tests)\n\nExamples:\n  reefgen bench generate --reps 50\n"
                                        "  reefgen bench train --ngf 64 --reps 5\n  reefgen bench infer --reps 20\n"
                                        "  reefgen bench realism          # the realism bars at 1025²\n"
                                        "  reefgen bench dataset          # dataset build pairs/s with erosion\n"
                                        "  bash scripts/bench-model.sh    # against the Python reference, as ratios\n");
  auto* gen = sub->add_subcommand("generate", "ms per island on one thread, islands/s on all cores");
  sub->require_subcommand(1);
  auto a = std::make_shared<BenchGenerateArgs>();
  gen->add_option("--size", a->size, "W")->capture_default_str();
  gen->add_option("--reps", a->reps, "Repetitions per single-thread figure (median)")->capture_default_str();
  gen->add_option("--strokes", a->strokes, "Wind strokes per island")->capture_default_str();
  gen->add_option("--threads", a->threads, "Threads for the throughput figure (default: all cores)");
  gen->add_option("--islands", a->islands, "Islands for the throughput figure")->capture_default_str();
  auto model_bench = add_bench_model_commands(sub);
  CLI::App* realism = nullptr;
  auto realism_bench = add_bench_realism_command(sub, g, &realism);
  CLI::App* dataset = nullptr;
  auto dataset_bench = add_bench_dataset_command(sub, g, &dataset);
  return {sub, [a, &g, gen, model_bench, realism, realism_bench, dataset, dataset_bench]() -> int {
            if (realism->parsed()) return realism_bench();
            if (dataset->parsed()) return dataset_bench();
            if (!gen->parsed()) return model_bench();
            return run_bench_generate(*a, g.quiet);
          }};
}

}  // namespace reefgen
