// reefgen eval-sketches: how a generator treats painted sketches, which have
// no ground truth (issue 11, docs/MODEL.md). Per sketch and overall: young
// land above the sea, young abyss deep, reef crest depth, checkerboard
// amplitude; a picture grid (sketch | result) to look at.
#include <algorithm>
#include <cstdio>
#include <optional>

#include <opencv2/imgproc.hpp>

#include "app.hpp"
#include "reefgen/infer/eval.hpp"
#include "reefgen/infer/infer.hpp"
#include "reefgen/io.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/preview.hpp"
#include "reefgen/train/fused_adam.hpp"
#include "reefgen/version.hpp"

namespace reefgen {

using nlohmann::json;

namespace {
double share(int64_t a, int64_t b) { return b ? double(a) / double(b) : std::nan(""); }
json num(double v) { return std::isfinite(v) ? json(std::round(v * 1e4) / 1e4) : json(nullptr); }
}  // namespace

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
            torch::set_num_threads(a->threads.value_or(default_threads()));
            train::keep_freed_memory();
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
            infer::SketchChecks total;
            std::vector<double> crests, boards;
            json per = json::array();
            std::vector<cv::Mat> tiles;
            Progress progress("eval-sketches", files.size(), g.quiet);
            for (size_t i = 0; i < files.size(); ++i) {
              const DecodedSketch s = read_sketch(files[i]);
              const cv::Mat1f pred = infer::infer_heights(gen, {s}, {})[0];
              const infer::SketchChecks c = infer::sketch_checks(pred, s, a->young_max);
              total.land_px += c.land_px;
              total.land_above_0 += c.land_above_0;
              total.abyss_px += c.abyss_px;
              total.abyss_below_0 += c.abyss_below_0;
              total.abyss_below_20 += c.abyss_below_20;
              if (std::isfinite(c.reef_crest_m)) crests.push_back(c.reef_crest_m);
              boards.push_back(c.checkerboard_m);
              double lo = 0, hi = 0;
              cv::minMaxLoc(pred, &lo, &hi);
              per.push_back({{"sketch", files[i].filename().string()},
                             {"young_land_above_0", num(share(c.land_above_0, c.land_px))},
                             {"young_abyss_below_0", num(share(c.abyss_below_0, c.abyss_px))},
                             {"young_abyss_below_minus20", num(share(c.abyss_below_20, c.abyss_px))},
                             {"reef_crest_m", num(c.reef_crest_m)},
                             {"checkerboard_m", num(c.checkerboard_m)},
                             {"min_m", num(lo)},
                             {"max_m", num(hi)}});
              cv::Mat3b shown = encode_labels(s.label, s.subsidence);
              cv::Mat tile;
              cv::Mat3b prev = render_preview(pred);
              if (prev.size() != shown.size()) cv::resize(prev, prev, shown.size());
              cv::hconcat(std::vector<cv::Mat>{shown, prev}, tile);
              cv::resize(tile, tile, cv::Size(512, 256), 0, 0, cv::INTER_AREA);
              tiles.push_back(tile);
              progress.tick(i + 1);
            }
            auto median = [](std::vector<double> v) {
              if (v.empty()) return std::nan("");
              std::sort(v.begin(), v.end());
              return v[v.size() / 2];
            };
            const double board_mean = std::accumulate(boards.begin(), boards.end(), 0.0) / double(boards.size());
            const json report = {
                {"reefgen_version", kVersion},
                {"model", {{"path", model_path.string()}, {"train_step", gen.train_step}}},
                {"sketches", files.size()},
                {"young_max_subsidence", a->young_max},
                {"overall",
                 {{"young_land_above_0", num(share(total.land_above_0, total.land_px))},
                  {"young_abyss_below_0", num(share(total.abyss_below_0, total.abyss_px))},
                  {"young_abyss_below_minus20", num(share(total.abyss_below_20, total.abyss_px))},
                  {"reef_crest_m_median", num(median(crests))},
                  {"checkerboard_m_mean", num(board_mean)},
                  {"checkerboard_m_max", num(*std::max_element(boards.begin(), boards.end()))}}},
                {"per_sketch", per}};
            if (!a->out.empty()) {
              StagedOutputs outputs;
              outputs.write(json_out, [&](const fs::path& t) { write_json_atomic(t, report); });
              // Two sketch|result tiles per row.
              std::vector<cv::Mat> rows;
              for (size_t i = 0; i < tiles.size(); i += 2) {
                cv::Mat right = i + 1 < tiles.size() ? tiles[i + 1] : cv::Mat(tiles[i].size(), tiles[i].type(), cv::Scalar::all(0));
                cv::Mat row;
                cv::hconcat(std::vector<cv::Mat>{tiles[i], right}, row);
                rows.push_back(row);
              }
              cv::Mat grid;
              cv::vconcat(rows, grid);
              outputs.write(grid_out, [&](const fs::path& t) { write_png(t, grid); });
              outputs.commit();
            }
            std::printf("%s\n", report.dump(1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
            return 0;
          }};
}

}  // namespace reefgen
