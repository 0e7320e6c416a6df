// reefgen eval: how good a generator is on a dataset split, and how robust to
// imperfect sketches (docs/INFERENCE.md). JSON on stdout and in OUT/eval.json,
// a Markdown table in OUT/eval.md, the worst cases in OUT/worst.png.
#include <cstdio>
#include <numeric>
#include <optional>

#include <opencv2/imgcodecs.hpp>

#include "app.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/infer/eval.hpp"
#include "reefgen/infer/infer.hpp"
#include "reefgen/io.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/preview.hpp"
#include "reefgen/train/data.hpp"
#include "reefgen/train/fused_adam.hpp"
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
    bool no_perturb = false, running_stats = false;
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
  sub->add_flag("--running-stats", a->running_stats, "BatchNorm running statistics instead of batch statistics");
  sub->add_option("--world-size", a->world_size_m, "Canvas width in metres (slopes)")->capture_default_str()->check(finite_in(1, 1e7));
  sub->add_option("--threads", a->threads, "LibTorch threads (default: all cores)")->check(CLI::Range(1, 256));
  return {sub, [a, &g]() -> int {
            torch::set_num_threads(a->threads.value_or(default_threads()));
            train::keep_freed_memory();
            if (a->max_pairs < 1) throw Error("--max-pairs must be ≥ 1");
            a->model = model::resolve_model_path(a->model).string();
            model::GeneratorFile gen = model::load_generator(a->model);
            const train::DatasetInfo data = train::open_dataset(a->data);
            const auto& pairs = data.split(a->split);
            if (pairs.empty()) throw Error(a->data + ": the " + a->split + " split is empty; try --split val or train");
            if (!a->out.empty()) ensure_writable_dir(a->out);
            const size_t n = std::min(pairs.size(), size_t(a->max_pairs));
            std::vector<cv::Mat3b> labels;
            std::vector<cv::Mat1f> truths;
            std::vector<DecodedSketch> clean;
            for (size_t i = 0; i < n; ++i) {
              const fs::path lp = data.dir / pairs[i].label;
              labels.push_back(read_image(lp, cv::IMREAD_COLOR));
              truths.push_back(read_exr_height(data.dir / pairs[i].height));
              for (const auto& [m, path] : {std::pair<cv::Size, fs::path>{labels.back().size(), lp},
                                             {truths.back().size(), data.dir / pairs[i].height}})
                if (m.width != data.size_px || m.height != data.size_px)
                  throw Error(path.string() + ": " + std::to_string(m.width) + "x" + std::to_string(m.height) +
                              ", not " + std::to_string(data.size_px) + "x" + std::to_string(data.size_px) +
                              " as dataset.json says; rebuild the dataset");
              if (!cv::checkRange(truths.back(), true))
                throw Error((data.dir / pairs[i].height).string() +
                            ": the true heights hold NaN or infinite values; rebuild the dataset (reefgen dataset build)");
              clean.push_back(decode_sketch(labels.back(), lp.string()));
            }
            std::vector<infer::Perturbation> kinds = {infer::Perturbation::None};
            if (!a->no_perturb)
              kinds.insert(kinds.end(), {infer::Perturbation::Blur, infer::Perturbation::Jpeg50,
                                         infer::Perturbation::HueJitter, infer::Perturbation::BrushNoise});
            infer::InferOptions io;
            io.running_stats = a->running_stats;
            json results = json::object();
            std::vector<double> clean_mae(n);
            std::vector<cv::Mat1f> clean_pred;
            Progress progress("eval", n * kinds.size(), g.quiet);
            size_t done = 0;
            for (const auto kind : kinds) {
              std::vector<DecodedSketch> sk;
              for (size_t i = 0; i < n; ++i)
                sk.push_back(kind == infer::Perturbation::None
                                 ? clean[i]
                                 : decode_sketch(infer::perturb(labels[i], kind, pairs[i].index), pairs[i].label));
              infer::MetricSums sums;
              for (size_t i = 0; i < n; ++i) {  // one at a time: progress, bounded memory
                const cv::Mat1f pred = infer::infer_heights(gen, {sk[i]}, io)[0];
                const infer::MetricSums m = infer::pair_metrics(pred, truths[i], clean[i].label, gen.range.lo_m,
                                                                gen.range.hi_m, a->world_size_m / pred.cols);
                sums.add(m);
                if (kind == infer::Perturbation::None) {
                  clean_mae[i] = m.abs_sum / double(m.pixels);
                  clean_pred.push_back(pred);
                }
                progress.tick(++done);
              }
              results[infer::perturbation_name(kind)] = sums.finish();
            }
            // Worst cases on clean sketches: label | truth | prediction.
            std::vector<size_t> order(n);
            std::iota(order.begin(), order.end(), 0);
            std::stable_sort(order.begin(), order.end(), [&](size_t x, size_t y) { return clean_mae[x] > clean_mae[y]; });
            json worst = json::array();
            std::vector<cv::Mat> rows;
            for (size_t k = 0; k < std::min<size_t>(4, n); ++k) {
              const size_t i = order[k];
              worst.push_back({{"index", pairs[i].index}, {"label", pairs[i].label},
                               {"mae_m", std::round(clean_mae[i] * 1e4) / 1e4}});
              cv::Mat row;
              cv::hconcat(std::vector<cv::Mat>{labels[i], render_preview(truths[i]), render_preview(clean_pred[i])}, row);
              rows.push_back(row);
            }
            const json report = {{"reefgen_version", kVersion},
                                 {"model", {{"path", a->model}, {"train_step", gen.train_step}, {"ngf", gen.g->options().ngf}}},
                                 {"data", a->data},
                                 {"split", a->split},
                                 {"pairs", n},
                                 {"batchnorm", a->running_stats ? "running statistics" : "batch statistics"},
                                 {"metrics", results},
                                 {"worst", worst}};
            if (!a->out.empty()) {
              write_json_atomic(fs::path(a->out) / "eval.json", report);
              std::string md = "| sketches | MAE (m) | RMSE (m) | SSIM | slope W1 (°) | coastline agreement |\n|---|---|---|---|---|---|\n";
              for (const auto kind : kinds) {
                const json& m = results[infer::perturbation_name(kind)];
                char line[256];
                std::snprintf(line, sizeof line, "| %s | %.2f | %.2f | %.4f | %.3f | %.4f |\n", infer::perturbation_name(kind),
                              m["mae_m"].get<double>(), m["rmse_m"].get<double>(), m["ssim"].get<double>(),
                              m["slope_w1_deg"].get<double>(), m["coastline_agreement"].get<double>());
                md += line;
              }
              md += "\nClean sketches, per region:\n\n| region | MAE (m) | RMSE (m) | pixel share |\n|---|---|---|---|\n";
              for (const char* name : kRegionNames) {
                const json& r = results["clean"]["per_region"][name];
                char line[160];
                std::snprintf(line, sizeof line, "| %s | %.2f | %.2f | %.3f |\n", name, r["mae_m"].get<double>(),
                              r["rmse_m"].get<double>(), r["pixel_share"].get<double>());
                md += line;
              }
              write_text_atomic(fs::path(a->out) / "eval.md", md);
              cv::Mat grid;
              cv::vconcat(rows, grid);
              write_png(fs::path(a->out) / "worst.png", grid);
            }
            std::printf("%s\n", report.dump(1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
            return 0;
          }};
}

}  // namespace reefgen
