// reefgen bench realism: the realism bars measured the way docs/REALISM.md
// defines them (bench::realism_bench) — N random specs generated at --size,
// and the painted sketches of tests/data/painted answered by `infer --size`.
// One JSON object on stdout, the CPU model included: figures depend on it.
#include <cstdio>
#include <optional>

#include <nlohmann/json.hpp>

#include "app.hpp"
#include "reefgen/bench/realism_bench.hpp"
#include "reefgen/io.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/parallel.hpp"

namespace reefgen {

std::function<int()> add_bench_realism_command(CLI::App* bench, const GlobalOptions& g, CLI::App** sub_out) {
  struct Args {
    int specs = 50, size = 1025;
    uint64_t seed = 1, painted_seed = 0;
    double subsidence = 0, variation = 1;
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
  sub->add_option("--variation", a->variation, "How far --painted-seed re-rolls each painted island (as infer --variation)")
      ->capture_default_str()
      ->check(finite_in(0, 1));
  return [a, &g]() -> int {
    bench::RealismBenchOptions o;
    o.specs = a->specs;
    o.size_px = a->size;
    o.spec_seed = a->seed;
    o.subsidence = a->subsidence;
    o.infer.seed = a->painted_seed;
    o.infer.variation = a->variation;
    o.quiet = g.quiet;
    std::vector<fs::path> files;
    std::optional<model::GeneratorFile> gen;
    fs::path model_path;
    if (!a->painted.empty()) {
      if (!fs::is_directory(a->painted)) throw Error(a->painted + ": no such folder of painted sketches (or --painted '')");
      files = images_in(a->painted);
      if (files.empty()) throw Error(a->painted + ": no sketch images in it");
      model_path = model::resolve_model_path(a->model);
      gen = model::load_generator(model_path);
      if (!a->erosion.empty()) o.infer.amplification = infer::amplify_params_from_json(read_json(a->erosion), a->erosion);
    }
    nlohmann::json out = {{"bench", "realism"}, {"size", a->size}, {"cpu", cpu_model()}};
    out.update(bench::realism_bench(o, gen ? &*gen : nullptr, files));
    if (gen) out["painted"]["model"] = model_path.string();
    std::printf("%s\n", out.dump(1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
    return 0;
  };
}

}  // namespace reefgen
