// reefgen eval-sketches: how a generator treats painted sketches, which have
// no ground truth (docs/MODEL.md). Per sketch and overall: young
// land above the sea, young abyss deep, reef crest depth, checkerboard
// amplitude; a picture grid (sketch | result) to look at.
#include <cstdio>
#include <optional>

#include "app.hpp"
#include "reefgen/infer/evaluate.hpp"
#include "reefgen/io.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/model/torch_threads.hpp"
#include "reefgen/version.hpp"

namespace reefgen {

using nlohmann::json;

Command add_eval_sketches_command(CLI::App& app, const GlobalOptions& g) {
  auto* sub = app.add_subcommand(
      "eval-sketches",
      "Check a generator on painted sketches without ground truth: share of young (bright)\n"
      "island+beach pixels above 0 m, young abyss below 0 m and below -20 m, reef crest\n"
      "height, 2-px checkerboard amplitude; writes OUT/sketches.json and OUT/grid.png\n\n"
      "Examples:\n"
      "  reefgen eval-sketches tests/data/painted --out out/eval-painted          # the shipped model\n"
      "  reefgen eval-sketches my-sketches/ -m runs/try/generator.pt --out out/e\n");
  struct Args {
    std::string dir, model, out;
    double young_max = 0.1;
    std::optional<int> threads;
  };
  auto a = std::make_shared<Args>();
  sub->add_option("sketches", a->dir, "Folder of painted sketches (PNG, JPEG, TIFF, BMP, WebP)")->required();
  sub->add_option("-m,--model", a->model, "Generator file (default: the shipped model, models/)");
  sub->add_option("-o,--out,--output", a->out, "Folder for sketches.json and grid.png (default: print JSON only)");
  sub->add_option("--young-max", a->young_max, "Subsidence up to which a pixel counts as young (bright)")
      ->capture_default_str();
  sub->add_option("--threads", a->threads, "LibTorch threads (default: all cores)")->check(CLI::Range(1, 256));
  return {sub, [a, &g]() -> int {
            model::use_torch_threads(a->threads.value_or(default_threads()));
            if (!(a->young_max >= 0 && a->young_max <= 1)) throw Error("--young-max must be in [0, 1]");
            if (!fs::is_directory(a->dir)) throw Error(a->dir + ": not a folder of sketches");
            const std::vector<fs::path> files = images_in(a->dir);
            if (files.empty()) throw Error(a->dir + ": no sketch images (.png, .jpg, ...) in it");
            const fs::path model_path = model::resolve_model_path(a->model);
            model::GeneratorFile gen = model::load_generator(model_path);
            const fs::path json_out = fs::path(a->out) / "sketches.json", grid_out = fs::path(a->out) / "grid.png";
            if (!a->out.empty()) {
              ensure_writable_dir(a->out);
              refuse_output_over_input(files, {json_out, grid_out});
            }
            const infer::SketchesResult r = infer::evaluate_sketches(gen, files, a->young_max, g.quiet);
            const json report = {
                {"reefgen_version", kVersion},
                {"model", {{"path", model_path.string()}, {"train_step", gen.train_step}}},
                {"sketches", files.size()},
                {"young_max_subsidence", a->young_max},
                {"overall", r.overall},
                {"per_sketch", r.per_sketch}};
            if (!a->out.empty()) {
              StagedOutputs outputs;
              outputs.write(json_out, [&](const fs::path& t) { write_json_atomic(t, report); });
              outputs.write(grid_out, [&](const fs::path& t) { write_png(t, r.grid); });
              outputs.commit();
            }
            std::printf("%s\n", report.dump(1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
            return 0;
          }};
}

}  // namespace reefgen
