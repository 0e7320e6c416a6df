// reefgen eval: how good a generator is on a dataset split, and how robust to
// imperfect sketches (docs/INFERENCE.md). JSON on stdout and in OUT/eval.json,
// a Markdown table in OUT/eval.md, the worst cases in OUT/worst.png.
#include <cstdio>
#include <optional>

#include "app.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/infer/evaluate.hpp"
#include "reefgen/files.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/model/torch_threads.hpp"
#include "reefgen/train/data.hpp"
#include "reefgen/version.hpp"

namespace reefgen {

using nlohmann::json;

Command add_eval_command(CLI::App& app, const GlobalOptions& g) {
  auto* sub = app.add_subcommand(
      "eval",
      "Measure a generator on a dataset split: MAE/RMSE (m) overall and per region, SSIM,\n"
      "slope-distribution distance, coastline agreement; and the same on perturbed sketches\n"
      "(blur, JPEG q50, hue jitter, brush noise)\n\n"
      "Examples:\n"
      "  reefgen eval -m runs/paper/generator.pt --data data/paper --split test --out runs/paper/eval\n"
      "  reefgen eval -m generator.pt --data data/small --max-pairs 50 --no-perturb\n");
  struct Args {
    std::string model, data, split = "test", out;
    int64_t max_pairs = 1000;
    bool no_perturb = false, running_stats = false, no_verify = false, raw = false;
    double world_size_m = kCanvasWorldSizeM;
    std::optional<int> threads;
  };
  auto a = std::make_shared<Args>();
  sub->add_option("-m,--model", a->model, "Generator exported by `reefgen train`"
                                          "; default: the shipped model (models/reef-256.pt, docs/MODEL.md)");
  sub->add_option("--data", a->data, "Dataset folder (`reefgen dataset build`)")->required();
  sub->add_option("--split", a->split, "train, val or test")->capture_default_str();
  sub->add_option("-o,--out,--output", a->out, "Folder for eval.json, eval.md, worst.png (default: print JSON only)");
  sub->add_option("--max-pairs", a->max_pairs, "Use the first N pairs of the split")->capture_default_str();
  sub->add_flag("--no-perturb", a->no_perturb, "Clean sketches only");
  sub->add_flag("--raw", a->raw, "Score the network's bare answer (infer --raw), not the cleaned one infer gives");
  sub->add_flag("--no-verify", a->no_verify, "Skip checking the dataset's files against its manifest's checksums");
  sub->add_flag("--running-stats", a->running_stats, "BatchNorm running statistics instead of batch statistics");
  sub->add_option("--world-size", a->world_size_m, "Canvas width in metres (slopes)")->capture_default_str()->check(finite_in(1, 1e7));
  sub->add_option("--threads", a->threads, "LibTorch threads (default: all cores)")->check(CLI::Range(1, 256));
  return {sub, [a, &g]() -> int {
            model::use_torch_threads(a->threads.value_or(default_threads()));
            if (a->max_pairs < 1) throw Error("--max-pairs must be ≥ 1");
            a->model = model::resolve_model_path(a->model).string();
            model::GeneratorFile gen = model::load_generator(a->model);
            augment::ManifestCheck check;
            check.verify_checksums = !a->no_verify;
            check.threads = a->threads.value_or(default_threads());
            check.quiet = g.quiet;
            const train::DatasetInfo data = train::open_dataset(a->data, check);
            const auto& pairs = data.split(a->split);
            if (pairs.empty()) throw Error(a->data + ": the " + a->split + " split is empty; try --split val or train");
            if (!a->out.empty()) ensure_writable_dir(a->out);
            const size_t n = std::min(pairs.size(), size_t(a->max_pairs));
            std::vector<infer::EvalPair> eval_pairs;
            for (size_t i = 0; i < n; ++i) {
              eval_pairs.push_back(infer::read_eval_pair(data.dir / pairs[i].label, data.dir / pairs[i].height,
                                                         data.size_px, pairs[i].index, pairs[i].label));
              eval_pairs.back().maturity = pairs[i].maturity;
            }
            infer::EvalOptions eo;
            eo.perturb = !a->no_perturb;
            eo.running_stats = a->running_stats;
            eo.world_size_m = a->world_size_m;
            eo.quiet = g.quiet;
            eo.raw = a->raw;
            const infer::EvalResult r = infer::evaluate(gen, eval_pairs, eo);
            const json report = {{"reefgen_version", kVersion},
                                 {"model", {{"path", a->model}, {"train_step", gen.train_step}, {"ngf", gen.g->options().ngf}}},
                                 {"data", a->data},
                                 {"split", a->split},
                                 {"pairs", n},
                                 {"batchnorm", a->running_stats ? "running statistics" : "batch statistics"},
                                 {"metrics", r.metrics},
                                 {"worst", r.worst}};
            if (!a->out.empty()) infer::write_eval_files(a->out, report, r.worst_sheet);
            std::printf("%s\n", report.dump(1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
            return 0;
          }};
}

}  // namespace reefgen
