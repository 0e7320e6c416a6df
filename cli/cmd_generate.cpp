// reefgen generate: one island from a preset or a spec file, or N random ones.
#include <cmath>
#include <cstdio>
#include <optional>

#include "app.hpp"
#include "reefgen/engines/bundle.hpp"
#include "reefgen/presets.hpp"
#include "reefgen/constants.hpp"
#include "finish.hpp"
#include "reefgen/terrain/ocean_floor.hpp"
#include "reefgen/gis/geotiff.hpp"
#include "reefgen/files.hpp"
#include "reefgen/procgen/output.hpp"
#include "reefgen/procgen/random_spec.hpp"

namespace reefgen {

using namespace procgen;

namespace {

struct GenerateArgs {
  std::string preset, spec_file, prefix, out_dir;
  int random = 0;
  bool random_given = false;
  double subsidence = NAN;  // NAN: keep the preset's / spec's value
  double age_myr = NAN;     // NAN: the spec's age_myr (procgen/age.hpp)
  double maturity = NAN;    // NAN: the spec's maturity
  int size = 256;
  uint64_t seed = 0;
  bool seed_given = false;
  bool preview = false;
  FinishFlags finish;
  int threads = default_threads();
  int levels = 4;
  int warp_grid = RenderOptions{}.warp_grid;
};

// The spec with --age-myr and --maturity written into its JSON before it is
// read (flags override the file; the age is applied once, by spec_from_json).
// age: the age and maturity it was read with (for the sidecar), null where not set.
IslandSpec load_spec(const GenerateArgs& a, nlohmann::json* age = nullptr) {
  nlohmann::json j;
  std::string origin;
  if (!a.preset.empty()) {
    j = nlohmann::json::parse(preset_text(builtin_presets(), a.preset)), origin = "preset " + a.preset;
  } else {
    if (!fs::exists(a.spec_file)) throw Error("cannot read " + a.spec_file + ": no such file");
    j = read_json(a.spec_file), origin = a.spec_file;
  }
  if (!std::isnan(a.age_myr)) j["age_myr"] = a.age_myr;
  if (!std::isnan(a.maturity)) j["maturity"] = a.maturity;
  if (age && j.is_object())
    for (const char* k : {"age_myr", "maturity"})
      if (j.contains(k)) (*age)[k] = j[k];
  return spec_from_json(j, origin);
}

void check_common(const GenerateArgs& a) {
  if (a.size < kMinGenerateSidePx || a.size > kMaxSidePx)
    throw Error("--size " + std::to_string(a.size) + " is out of range; expected " + std::to_string(kMinGenerateSidePx) +
                ".." + std::to_string(kMaxSidePx));
  if (!std::isnan(a.subsidence) && !(a.subsidence >= 0 && a.subsidence <= 1))
    throw Error("--subsidence must be in [0, 1]");
  if (a.threads < 1 || a.threads > 256) throw Error("--threads must be in 1..256");
  if (a.random_given && (!std::isnan(a.age_myr) || !std::isnan(a.maturity)))
    throw Error("--age-myr and --maturity set one island's age; use them with --preset or --spec, not --random");
}

int run_single(const GenerateArgs& a, const GlobalOptions& g) {
  nlohmann::json age;
  IslandSpec spec = load_spec(a, &age);
  if (!std::isnan(a.subsidence)) spec.subsidence = a.subsidence;
  if (a.seed_given) spec.noise.seed = a.seed;
  const OutputNames names = output_names(a.prefix);
  const fs::path prefix = names.prefix;
  const FinishFlags::Parsed fin = a.finish.parse();
  if (!a.spec_file.empty()) {  // the sidecar PREFIX.json must never replace the spec it was made from
    engines::PlannedOutputs planned = engines::planned_outputs(prefix, fin.bundles);
    planned.files.push_back(names.height);
    planned.files.push_back(prefix.string() + ".label.png");
    engines::refuse_outputs_over_inputs({a.spec_file}, planned);
  }
  ensure_writable_dir(prefix.parent_path());
  RenderOptions opt;
  opt.size_px = a.size;
  opt.warp_grid = a.warp_grid;
  note_bundle_sizes(fin, a.size, g.quiet);
  opt.keep_uneroded = fin.need_layers;
  IslandFields f = generate(spec, opt);
  const double mpp = spec.world_size_m / opt.size_px;
  if (a.finish.ocean_floor_m < 0) {
    terrain::deepen_flank(f.height_m, a.finish.ocean_floor_m, mpp, f.label);
    if (!f.uneroded_m.empty()) terrain::deepen_flank(f.uneroded_m, a.finish.ocean_floor_m, mpp, f.label);
  }
  nlohmann::json prov = {{"mode", a.preset.empty() ? "spec" : "preset"},
                         {"source", a.preset.empty() ? a.spec_file : a.preset},
                         {"warp_grid", opt.warp_grid}};
  if (a.finish.ocean_floor_m < 0) prov["ocean_floor_m"] = a.finish.ocean_floor_m;
  // The spec written beside the island has the age applied (its subsidence
  // and erosion); what it was asked for is kept here.
  if (!age.is_null()) prov["age"] = age;
  const ExtraFiles finishing = [&](StagedOutputs& staged, nlohmann::json& side, const terrain::Layers* L) {
    if (a.finish.geotiff) side["geotiff"] = gis::stage_geotiff_files(staged, prefix.string(), f.height_m, L, mpp, fin.geo, a.threads);
    if (!fin.bundles.empty())
      side["bundles"] = engines::stage_bundles(staged, prefix, fin.bundles, {f.height_m, L, mpp, fin.geo}, a.threads);
  };
  const auto w = write_island(prefix, f, spec, prov, a.preview, names.height, fin.need_layers ? &fin.rules : nullptr,
                              a.threads, finishing, a.finish.layers);
  for (const auto& p : w.files) std::printf("%s\n", p.c_str());
  return 0;
}

int run_random(const GenerateArgs& a, const GlobalOptions& g) {
  const fs::path dir = a.out_dir;
  ensure_writable_dir(dir);
  RandomIslands r;
  r.count = a.random;
  r.levels = a.levels;
  r.seed = a.seed;
  r.render.size_px = a.size;
  r.render.warp_grid = a.warp_grid;
  r.preview = a.preview;
  const FinishFlags::Parsed fin = a.finish.parse();
  r.layers = a.finish.layers;
  r.layer_params = fin.rules;
  r.threads = a.threads;
  if (a.levels < 1 || a.levels > 64) throw Error("--levels must be in 1..64");
  if (a.finish.geotiff) throw Error("--geotiff: one island at a time (--preset or --spec), not --random; or convert with `reefgen erode`");
  if (!fin.bundles.empty()) throw Error("--for: one island at a time (--preset or --spec), not --random");
  Progress progress("generate", size_t(a.random) * size_t(a.levels), g.quiet);
  const RandomIslandsResult res = write_random_islands(dir, r, [&](size_t done) { progress.tick(done); });
  if (!g.quiet)
    std::fprintf(stderr, "wrote %zu islands (%zu already there) to %s\n", res.total - res.skipped, res.skipped,
                 dir.c_str());
  std::printf("%s\n", dir.c_str());
  return 0;
}

}  // namespace

Command add_generate_command(CLI::App& app, const GlobalOptions& g) {
  auto a = std::make_shared<GenerateArgs>();
  auto* sub = app.add_subcommand("generate", "Generate islands with the curve-based procedural generator\n\n"
                                             "Examples:\n"
                                             "  reefgen generate --preset young-volcano -o out/volcano --preview\n"
                                             "  reefgen generate --preset atoll --subsidence 1 --size 512 -o out/atoll\n"
                                             "  reefgen generate --preset young-volcano --age-myr 5 --size 1025 -o out/old   # Kauai's age\n"
                                             "  reefgen generate --spec docs/examples/spec.json -o out/mine\n"
                                             "  reefgen generate --preset barrier-reef --size 1025 -o out/reef --for unity,unreal,gis\n"
                                             "  reefgen generate --random 50 --seed 1 --out out/random --threads 2\n");
  auto* src = sub->add_option_group("source", "What to generate");
  src->add_option("--preset", a->preset, "Built-in preset (see `reefgen presets`)");
  src->add_option("--spec,--config", a->spec_file, "Island spec JSON (docs/SPEC.md); --config is the same");
  src->add_option("--random", a->random, "N random configurations (paper's data generation), each at --levels subsidence levels")
      ->each([a](const std::string&) { a->random_given = true; });
  src->require_option(1);
  sub->add_option("-o,--output", a->prefix, "Output prefix: PREFIX.height.exr, .label.png, .json (and .preview.png); or NAME.exr: that file, siblings NAME.*");
  sub->add_option("--out", a->out_dir, "Output folder for --random");
  sub->add_option("--subsidence", a->subsidence, "Override the subsidence λ in [0, 1] (also after --age-myr)")->check(finite_in(0, 1));
  sub->add_option("--age-myr", a->age_myr,
                  "Island age in My: sets the subsidence and the erosion maturity together (docs/SPEC.md \"Age\": "
                  "0.25 a young shield, 3.5 Bora Bora, 60 an atoll)")
      ->check(finite_in(0, 60));
  sub->add_option("--maturity", a->maturity,
                  "Erosion maturity alone (time eroded, multiple of the default; overrides the age's)")
      ->check(finite_in(0.05, 20));
  sub->add_option("--size", a->size, "Width W of the W×W output in pixels")->capture_default_str();
  sub->add_option("--seed", a->seed, "Random seed (random mode) or detail-noise seed (preset/spec)")
      ->check(seed_value())
      ->each([a](const std::string&) { a->seed_given = true; });
  sub->add_flag("--preview", a->preview, "Also write PREFIX.preview.png (hill-shaded colours)");
  add_finish_flags(sub, a->finish);
  sub->add_option("--threads", a->threads, "Worker threads for --random and --layers (default: all cores)")->check(CLI::Range(1, 256));
  sub->add_option("--levels", a->levels, "Subsidence levels per random configuration, evenly spaced on [0, 1]")->capture_default_str();
  sub->add_option("--warp-grid", a->warp_grid, "Cells of the wind displacement grid across the canvas")->capture_default_str();
  return {sub, [a, &g]() -> int {
            check_common(*a);
            if (a->random_given) {
              if (a->random < 1 || a->random > 10'000'000)
                throw Error("--random " + std::to_string(a->random) + ": the number of islands must be in 1..10000000");
              if (a->out_dir.empty()) throw Error("--random needs --out DIR");
              return run_random(*a, g);
            }
            if (a->prefix.empty()) throw Error("missing -o PREFIX (output prefix, e.g. -o out/island)");
            return run_single(*a, g);
          }};
}

Command add_presets_command(CLI::App& app, const GlobalOptions&) {
  auto* sub = app.add_subcommand("presets", "List the built-in island presets (configs/presets/*.json)");
  return {sub, [] {
            for (const auto& [name, text] : builtin_presets()) {
              const auto j = nlohmann::json::parse(text);
              std::printf("%-16s %s\n", name.c_str(), j.value("description", "").c_str());
            }
            return 0;
          }};
}

}  // namespace reefgen
