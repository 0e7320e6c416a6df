// reefgen world: a sketch of a whole sea at the model's own scale → one
// drained height field, its layers and engine bundles (docs/WORLDS.md).
// Thin: flags → infer::WorldJob → infer::run_world (infer/world_run.hpp).
#include <optional>

#include "app.hpp"
#include "finish.hpp"
#include "reefgen/age.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/files.hpp"
#include "reefgen/infer/amplify.hpp"
#include "reefgen/infer/world_run.hpp"
#include "reefgen/io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/model/torch_threads.hpp"
#include "reefgen/parallel.hpp"

namespace reefgen {

namespace {
struct WorldArgs {
  std::string sketch, model, out;
  double metres_per_px = 0, world_size_m = 0;
  int size = 0;
  uint64_t seed = 0;
  double variation = 1.0;
  double age_myr = kNotSet, maturity = kNotSet;  // reefgen/age.hpp, as infer's
  bool raw = false, png16 = false, r16 = false, preview = false;
  FinishFlags finish;
  std::string precision = "fp32", engine = "auto";
  std::optional<int> threads;
};

// The job the flags ask for (the sketch's scale and the model are set once
// the sketch is read).
infer::WorldJob world_job(const WorldArgs& a, int threads, bool quiet) {
  const FinishFlags::Parsed fin = a.finish.parse();
  infer::WorldJob job;
  job.sketch = a.sketch;
  job.prefix = a.out;
  job.size = a.size;
  job.options.age_myr = a.age_myr;
  job.options.maturity = a.maturity;
  job.raw = a.raw;
  job.files.png16 = a.png16;
  job.files.r16 = a.r16;
  job.files.preview = a.preview;
  job.options.precision = infer::precision_from_string(a.precision);
  job.options.engine = infer::engine_from_string(a.engine);
  job.options.seed = a.seed;
  job.options.variation = a.variation;
  job.layers = a.finish.layers;
  job.need_layers = fin.need_layers;
  job.layer_rules = fin.rules;
  job.geotiff = a.finish.geotiff;
  job.geo = fin.geo;
  job.bundles = fin.bundles;
  job.ocean_floor_m = a.finish.ocean_floor_m;
  job.flags_key = {a.png16, a.r16, a.preview, a.finish.layers, a.finish.geotiff, a.finish.crs, a.finish.origin,
                   a.finish.engines};
  job.threads = threads;
  job.quiet = quiet;
  return job;
}
}  // namespace

Command add_world_command(CLI::App& app, const GlobalOptions& g) {
  auto a = std::make_shared<WorldArgs>();
  auto* sub = app.add_subcommand(
      "world",
      "A sketch of a whole sea, read at the model's own scale (23.4 m a pixel), into one drained height field.\n"
      "Past 8192² the layers and bundles come in tiles. An interrupted run (Ctrl-C, a full disk) keeps its\n"
      "finished work in PREFIX.partial/: the same command resumes it. The engine bundles (--for unity, unreal,\n"
      "godot, blender) take square worlds only (paint a square sketch); --for gis takes any shape.\n\n"
      "Examples:\n"
      "  reefgen sketch random --size 2048x2048 --seed 1 -o sea.png\n"
      "  reefgen world sea.png -o out/sea --size 8192 --preview      # 48 km across, 5.9 m a pixel\n"
      "  reefgen world sea.png -o out/sea --size 8192 --for unity,unreal --layers\n"
      "  reefgen world sea.png -o out/sea --size 16385 --for gis        # GeoTIFF tiles + a VRT mosaic\n"
      "  reefgen world sea.png -o out/sea --size 16385 --layers --for unity,unreal   # layers and engine tiles\n"
      "  reefgen world painted.png --world-size 30000 --raw -o out/w # the sketch's width is 30 km\n");
  sub->add_option("sketch", a->sketch, "Sketch image (any size and aspect)")->required();
  sub->add_option("-o,--output,--out", a->out, "Output prefix: PREFIX.height.exr, PREFIX.json, ...")->required();
  sub->add_option("-m,--model", a->model, "Generator (default: the shipped model)");
  sub->add_option("--metres-per-px", a->metres_per_px, "Ground of one sketch pixel, m (default 23.4: the model's)")
      ->check(finite_in(1e-3, 1e4));
  sub->add_option("--world-size", a->world_size_m, "Width of the whole sketch, m (instead of --metres-per-px)")
      ->check(finite_in(1, 1e8));
  sub->add_option("--size", a->size,
                  "Output size in pixels along the longer side, up to 16385 (default: the sketch's at the model's "
                  "scale). Larger: amplified (erosion and detail at each finer level, docs/WORLDS.md)")
      ->check(CLI::Range(kMinInferSidePx, infer::kMaxWorldSidePx));
  sub->add_option("--seed", a->seed,
                  "Other islands for the same painting: summits, ridges and valleys re-rolled inside the painted land, "
                  "and the amplification's detail noise")
      ->capture_default_str()
      ->check(seed_value());
  sub->add_option("--variation", a->variation, "How far --seed re-rolls the islands, 0..1 (0: the network's islands, the seed varying only the finer detail)")
      ->capture_default_str()
      ->check(finite_in(0, 1));
  sub->add_option("--age-myr", a->age_myr,
                  "The islands' age in My (as infer's: their subsidence replaces the painted brightness, their "
                  "erosion maturity sets the amplification's; docs/SPEC.md \"Age\")")
      ->check(finite_in(0, kMaxAgeMyr));
  sub->add_option("--maturity", a->maturity, "Erosion maturity alone, over the age's (as infer's)")
      ->check(finite_in(kMinMaturity, kMaxMaturity));
  sub->add_flag("--raw", a->raw, "The network's bare answer at the model's scale: no clean-up, no amplification");
  sub->add_flag("--png16", a->png16, "Also PREFIX.height.png: 16-bit linear, range in the sidecar");
  sub->add_flag("--r16", a->r16, "Also PREFIX.r16: little-endian RAW");
  sub->add_flag("--preview", a->preview, "Also PREFIX.preview.png: coloured, hill-shaded");
  add_finish_flags(sub, a->finish);
  sub->add_option("--precision", a->precision, "fp32, bf16 or auto (as infer)")->capture_default_str();
  sub->add_option("--engine", a->engine, "onednn, torch or auto (as infer)")->capture_default_str();
  sub->add_option("--threads", a->threads, "Threads (default: all cores)")->check(CLI::Range(1, 256));
  return {sub, [a, &g]() -> int {
            const int threads = a->threads.value_or(default_threads());
            model::use_torch_threads(threads);
            if (a->metres_per_px > 0 && a->world_size_m > 0)
              throw Error("--metres-per-px and --world-size say the same thing; give one");
            if (a->raw && a->size > 0) throw Error("--raw keeps the model's scale; drop --size or --raw");
            infer::WorldJob job = world_job(*a, threads, g.quiet);
            infer::refuse_world_over_sketch(job);
            if (!fs::is_regular_file(a->sketch)) throw Error(a->sketch + ": no such sketch file");
            const DecodedSketch s = read_sketch(a->sketch);
            infer::check_world_finish(job, s.label.rows == s.label.cols);
            ensure_writable_dir(job.prefix.has_parent_path() ? job.prefix.parent_path() : fs::path("."));
            job.sketch_metres_per_px = a->world_size_m > 0    ? a->world_size_m / s.label.cols
                                       : a->metres_per_px > 0 ? a->metres_per_px
                                                              : kModelMetresPerPx;
            job.model_path = model::resolve_model_path(a->model).string();
            model::GeneratorFile gen = model::load_generator(job.model_path);
            infer::run_world(gen, s, job);
            return 0;
          }};
}

}  // namespace reefgen
