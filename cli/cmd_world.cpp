// reefgen world: a sketch of a whole sea at the model's own scale → one
// drained height field (docs/WORLDS.md). Thin: flags → infer's world → files.
#include <chrono>
#include <cstdio>
#include <optional>

#include "app.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/infer/amplify.hpp"
#include "reefgen/infer/world.hpp"

#include <opencv2/imgproc.hpp>
#include "reefgen/io.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/parallel.hpp"
#include "reefgen/train/fused_adam.hpp"

namespace reefgen {

namespace {
struct WorldArgs {
  std::string sketch, model, out;
  double metres_per_px = 0, world_size_m = 0;
  int size = 0;
  uint64_t seed = 0;
  bool raw = false;
  std::string precision = "fp32", engine = "auto";
  std::optional<int> threads;
};
}  // namespace

Command add_world_command(CLI::App& app, const GlobalOptions& g) {
  auto a = std::make_shared<WorldArgs>();
  auto* sub = app.add_subcommand(
      "world",
      "A sketch of a whole sea, read at the model's own scale (23.4 m a pixel), into one height field\n\n"
      "Examples:\n"
      "  reefgen sketch random --size 2048x2048 --seed 1 -o sea.png\n"
      "  reefgen world sea.png -o out/sea                        # 48 km across\n"
      "  reefgen world painted.png --world-size 30000 -o out/w   # the sketch's width is 30 km\n");
  sub->add_option("sketch", a->sketch, "Sketch image (any size and aspect)")->required();
  sub->add_option("-o,--output,--out", a->out, "Output prefix: PREFIX.height.exr")->required();
  sub->add_option("-m,--model", a->model, "Generator (default: the shipped model)");
  sub->add_option("--metres-per-px", a->metres_per_px, "Ground of one sketch pixel, m (default 23.4: the model's)")
      ->check(finite_in(1e-3, 1e4));
  sub->add_option("--world-size", a->world_size_m, "Width of the whole sketch, m (instead of --metres-per-px)")
      ->check(finite_in(1, 1e8));
  sub->add_option("--size", a->size,
                  "Output side in pixels, up to 16385 (a square world; default: the sketch's side at the model's "
                  "scale). Larger: amplified (erosion and detail at each finer level, docs/WORLDS.md)")
      ->check(CLI::Range(kMinInferSidePx, infer::kMaxWorldSidePx));
  sub->add_option("--seed", a->seed, "The amplification's detail noise")->capture_default_str()->check(seed_value());
  sub->add_flag("--raw", a->raw, "The network's bare answer: no clean-up, no amplification");
  sub->add_option("--precision", a->precision, "fp32, bf16 or auto (as infer)")->capture_default_str();
  sub->add_option("--engine", a->engine, "onednn, torch or auto (as infer)")->capture_default_str();
  sub->add_option("--threads", a->threads, "LibTorch threads (default: all cores)")->check(CLI::Range(1, 256));
  return {sub, [a, &g]() -> int {
            torch::set_num_threads(a->threads.value_or(default_threads()));
            train::keep_freed_memory();
            if (a->metres_per_px > 0 && a->world_size_m > 0)
              throw Error("--metres-per-px and --world-size say the same thing; give one");
            if (!fs::is_regular_file(a->sketch)) throw Error(a->sketch + ": no such sketch file");
            const DecodedSketch s = read_sketch(a->sketch);
            if (!a->raw && s.label.rows != s.label.cols)
              throw Error(a->sketch + ": amplifying a world needs a square sketch for now; use --raw for any aspect");
            const double mpp = a->world_size_m > 0   ? a->world_size_m / s.label.cols
                               : a->metres_per_px > 0 ? a->metres_per_px
                                                      : kModelMetresPerPx;
            model::GeneratorFile gen = model::load_generator(model::resolve_model_path(a->model).string());
            infer::InferOptions io;
            io.precision = infer::precision_from_string(a->precision);
            io.engine = infer::engine_from_string(a->engine);
            const auto t0 = std::chrono::steady_clock::now();
            const cv::Mat1f h = infer::world_model_heights(gen, s, mpp, io);
            const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            if (!g.quiet) std::fprintf(stderr, "world: %dx%d px at %.1f m, model pass %.1f s\n", h.cols, h.rows,
                                       kModelMetresPerPx, secs);
            const double world_m = h.cols * kModelMetresPerPx;
            cv::Mat1f out = h;
            if (!a->raw) {
              const int N = a->size > 0 ? a->size : h.cols;
              cv::Mat1b label;
              const auto t1 = std::chrono::steady_clock::now();
              if (!g.quiet) std::fprintf(stderr, "world: amplifying to %d² ...\n", N);
              Progress progress("world: last level, bands", size_t((N + infer::kWorldBandRowsPx - 1) / infer::kWorldBandRowsPx),
                                g.quiet);
              out = infer::amplify_world(h, s.label, N, world_m, a->seed, io.erosion,
                                         [&](int done, int) { progress.tick(size_t(done)); });
              cv::min(cv::max(out, gen.range.lo_m), gen.range.hi_m, out);
              if (!g.quiet)
                std::fprintf(stderr, "world: amplified to %d² in %.1f s\n", out.cols,
                             std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count());
            }
            const fs::path exr = a->out + ".height.exr";
            refuse_output_over_input({fs::path(a->sketch)}, {exr});
            if (exr.has_parent_path()) ensure_writable_dir(exr.parent_path());
            write_exr_height(exr, out, {{"reefgen:metres_per_pixel", std::to_string(world_m / out.cols)}});
            std::printf("%s\n", exr.c_str());
            return 0;
          }};
}

}  // namespace reefgen
