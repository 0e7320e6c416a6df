// reefgen infer: painted sketches -> height fields in the formats terrain
// tools import (docs/INFERENCE.md). Thin: inputs -> infer library -> files.
#include <cstdio>
#include <optional>

#include "app.hpp"
#include "finish.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/infer/infer.hpp"
#include "reefgen/infer/run.hpp"
#include "reefgen/files.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/model/torch_threads.hpp"

namespace reefgen {

namespace {

struct InferArgs {
  std::vector<std::string> inputs;
  std::string model, out, mesh, erosion;
  bool png16 = false, r16 = false, preview = false, stochastic = false, running_stats = false, raw = false;
  FinishFlags finish;
  std::string precision = "fp32";  // the same heights on every CPU; bf16/auto are faster (docs/BENCHMARKS.md)
  std::string engine = "auto";
  uint64_t seed = 0;
  double variation = 1.0;
  double age_myr = kNotSet, maturity = kNotSet;
  int variations = 1;
  double exaggeration = 1.0, world_size_m = kCanvasWorldSizeM;
  int size = 0;
  std::optional<int> threads;
};

void add_infer_options(CLI::App* sub, InferArgs& a) {
  sub->add_option("sketches", a.inputs, "Sketch images or folders of them")->required();
  sub->add_option("-m,--model", a.model, "Generator exported by `reefgen train` (RUN/generator.pt)"
                                          "; default: the shipped model (models/reef-256.pt, docs/MODEL.md)");
  sub->add_option("-o,--output,--out", a.out,
                  "One sketch: output prefix (PREFIX.height.exr, PREFIX.json, ...) or NAME.exr (that file, siblings NAME.*). Several: a folder")->required();
  sub->add_flag("--png16", a.png16, "Also PREFIX.height.png: 16-bit linear, range in the sidecar");
  sub->add_flag("--r16", a.r16, "Also PREFIX.r16: little-endian RAW for Unity/Unreal (import numbers printed)");
  sub->add_option("--mesh", a.mesh, "Also a grid mesh: obj or glb (per sketch), or a path ending in .obj/.glb (one sketch)");
  sub->add_option("--exaggeration", a.exaggeration, "Vertical exaggeration of the mesh")->capture_default_str();
  sub->add_option("--world-size", a.world_size_m, "Canvas width in metres (mesh spacing, RAW import numbers)")->capture_default_str()->check(finite_in(1, 1e7));
  sub->add_option("--size", a.size,
                  "Output side in pixels, up to 8192 (default: the sketch's own). Above the model's 256: amplified "
                  "(erosion carves valleys at each finer level, docs/EROSION.md), e.g. 1025/2049/4097 for Unity, "
                  "1009/2017/4033 for Unreal")
      ->check(CLI::Range(kMinInferSidePx, kMaxSidePx));
  sub->add_option("--erosion", a.erosion,
                  "FILE: a JSON file of the amplification's erosion params (docs/EROSION.md; every key optional, "
                  "e.g. {\"amplify_roughness\": 0.5})")
      ->type_name("FILE");
  sub->add_flag("--preview", a.preview, "Also PREFIX.preview.png: coloured, hill-shaded");
  add_finish_flags(sub, a.finish);
  sub->add_flag("--stochastic", a.stochastic, "Dropout on (pix2pix's noise): a different island per --seed");
  sub->add_option("--seed", a.seed,
                  "Another island for the same painting: summit, ridges and valleys re-rolled inside the painted "
                  "land (docs/INFERENCE.md \"Variations\"); also the dropout masks of --stochastic")
      ->capture_default_str()
      ->check(seed_value());
  sub->add_option("--variation", a.variation,
                  "How far --seed re-rolls the island, 0..1 (0: the network's island, the seed varying only the finer detail)")
      ->capture_default_str()
      ->check(finite_in(0, 1));
  sub->add_option("--age-myr", a.age_myr,
                  "Island age in My (docs/SPEC.md \"Age\"): its subsidence replaces the painted brightness and its "
                  "erosion maturity sets the amplification's (0.25 a young shield, 3.5 Bora Bora)")
      ->check(finite_in(0, kMaxAgeMyr));
  sub->add_option("--maturity", a.maturity,
                  "Erosion maturity alone (multiple of the default erosion time; below 1 a young shield's shallow "
                  "gullies), over the age's")
      ->check(finite_in(kMinMaturity, kMaxMaturity));
  sub->add_option("--variations", a.variations,
                  "N islands of the one sketch, seeds --seed … --seed + N - 1, each to PREFIX.seedS.* with all its "
                  "files, and PREFIX.variations.png side by side: pick one and keep its seed (the network runs once)")
      ->capture_default_str()
      ->check(CLI::Range(1, infer::kMaxVariations));
  sub->add_option("--precision", a.precision,
                  "fp32, bf16 (heights within ~1 m of fp32, ~1.6x faster), or auto (bf16 where the CPU has "
                  "avx512_bf16 or AMX-bf16, else fp32)")
      ->capture_default_str();
  sub->add_option("--engine", a.engine,
                  "onednn (reefgen's engine), torch (LibTorch's forward, the reference) or auto (onednn; torch "
                  "with --stochastic)")
      ->capture_default_str();
  sub->add_flag("--raw", a.raw,
                "The network's bare answer (research): no clean-up at the model's side, no amplification above it");
  sub->add_flag("--running-stats", a.running_stats,
                "BatchNorm running statistics (eval mode) instead of pix2pix's test-time batch statistics");
  sub->add_option("--threads", a.threads, "LibTorch threads (default: all cores)")->check(CLI::Range(1, 256));
}

// The files to read and write, and how to finish them.
infer::InferJob infer_job(const InferArgs& a, const GlobalOptions& g) {
  infer::InferJob job;
  job.inputs = infer::sketch_inputs(a.inputs);
  job.out = a.out;
  job.mesh = a.mesh;
  job.files.png16 = a.png16;
  job.files.r16 = a.r16;
  job.files.preview = a.preview;
  job.files.exaggeration = a.exaggeration;
  const FinishFlags::Parsed fin = a.finish.parse();
  job.layers = a.finish.layers;
  job.layer_params = fin.rules;
  job.geotiff = a.finish.geotiff;
  job.geo = fin.geo;
  job.bundles = fin.bundles;
  job.variations = a.variations;
  // The output side when --size gives it (else each sketch's own, said in its bundle's README).
  if (a.size > 0) note_bundle_sizes(fin, a.size, g.quiet);
  return job;
}

// How the network runs and what follows its answer (--precision, --engine, --raw, --size, --erosion).
void set_infer_options(const InferArgs& a, model::GeneratorFile& gen, const std::string& model_path, bool quiet,
                       infer::InferOptions& io) {
  io.stochastic = a.stochastic;
  io.running_stats = a.running_stats;
  if (a.running_stats && gen.g->options().norm != model::Norm::Batch && !quiet)
    std::fprintf(stderr, "note: --running-stats changes nothing: %s has no BatchNorm (it uses %s)\n",
                 model_path.c_str(), gen.g->options().norm == model::Norm::Instance ? "instance norm" : "no normalisation");
  io.amplify = !a.raw;
  try {
    io.precision = infer::precision_from_string(a.precision);
    io.engine = infer::engine_from_string(a.engine);
    infer::resolve(io, gen);
  } catch (const Error& e) {
    throw Error("--precision/--engine: " + std::string(e.what()));
  }
  io.seed = a.seed;
  io.variation = a.variation;
  io.age_myr = a.age_myr;
  io.maturity = a.maturity;
  io.size_px = a.size;
  io.world_size_m = a.world_size_m;
  io.ocean_floor_m = a.finish.ocean_floor_m;
  if (!a.erosion.empty()) io.amplification = infer::amplify_params_from_json(read_json(a.erosion), a.erosion);
}

int run_infer(const InferArgs& a, const GlobalOptions& g) {
  model::use_torch_threads(a.threads.value_or(default_threads()));
  infer::InferJob job = infer_job(a, g);
  job.threads = a.threads.value_or(default_threads());
  job.quiet = g.quiet;
  job.model_path = model::resolve_model_path(a.model).string();
  model::GeneratorFile gen = model::load_generator(job.model_path);
  set_infer_options(a, gen, job.model_path, g.quiet, job.options);
  Progress progress("infer", job.inputs.files.size(), g.quiet);
  const infer::InferResult r = infer::infer_files(gen, job, [&](size_t k) { progress.tick(k); });
  if (!g.quiet) {
    for (const auto& n : r.r16_notes) std::fprintf(stderr, "%s", n.c_str());
    for (const auto& n : r.world_notes) std::fprintf(stderr, "note: %s\n", n.c_str());
  }
  // Data on stdout: every file written, as `generate` lists them.
  for (const auto& f : r.files) std::printf("%s\n", f.c_str());
  return 0;
}

}  // namespace

Command add_infer_command(CLI::App& app, const GlobalOptions& g) {
  auto* sub = app.add_subcommand(
      "infer",
      "Turn painted label sketches into height fields with a trained generator\n\n"
      "Colours (paper §7): red abyss, blue reef, cyan lagoon, green beach, yellow island (mountain);\n"
      "darker = more subsidence. Any size (resized to the model's side and back), PNG/JPEG,\n"
      "8/16-bit, alpha, anti-aliased brushes.\n\n"
      "Examples:\n"
      "  reefgen infer sketch.png -o out/island --preview                 # the shipped model\n"
      "  reefgen infer sketch.png -m runs/paper/generator.pt -o out/island --preview\n"
      "  reefgen infer sketches/ -m generator.pt -o out/ --png16 --r16\n"
      "  reefgen infer sketch.png -m generator.pt -o out/island --mesh out/island.glb --exaggeration 3\n"
      "  reefgen infer sketch.png -o out/v2 --size 1025 --seed 2            # another island, same painting\n"
      "  reefgen infer sketch.png -o out/mean --variation 0                 # the network's island, no re-roll\n"
      "  reefgen infer sketch.png -o out/isle --size 1025 --variations 4    # 4 islands side by side: isle.variations.png\n"
      "  reefgen infer sketch.png -m generator.pt -o out/v --stochastic --seed 7\n"
      "  reefgen infer sketch.png -o out/island --size 2017 --for unreal,gis\n");
  auto a = std::make_shared<InferArgs>();
  add_infer_options(sub, *a);
  return {sub, [a, &g]() -> int { return run_infer(*a, g); }};
}

}  // namespace reefgen
