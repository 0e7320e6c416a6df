#include "reefgen/infer/evaluate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/infer/infer.hpp"
#include "reefgen/io.hpp"
#include "reefgen/stats.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/parallel.hpp"
#include "reefgen/preview.hpp"

namespace reefgen::infer {

using nlohmann::json;

EvalPair read_eval_pair(const std::filesystem::path& label, const std::filesystem::path& height, int size_px,
                        int64_t index, const std::string& name) {
  EvalPair p;
  p.label_bgr = read_image(label, cv::IMREAD_COLOR);
  p.truth_m = read_exr_height(height);
  p.index = index;
  p.name = name;
  for (const auto& [m, path] : {std::pair<cv::Size, std::filesystem::path>{p.label_bgr.size(), label}, {p.truth_m.size(), height}})
    if (m.width != size_px || m.height != size_px)
      throw Error(path.string() + ": " + std::to_string(m.width) + "x" + std::to_string(m.height) + ", not " +
                  std::to_string(size_px) + "x" + std::to_string(size_px) + " as dataset.json says; rebuild the dataset");
  if (!cv::checkRange(p.truth_m, true))
    throw Error(height.string() + ": the true heights hold NaN or infinite values; rebuild the dataset (reefgen dataset build)");
  return p;
}

namespace {
// A generator with the maturity channel is asked for the pair's maturity (and
// amplified at it, as `infer --maturity` would); any other reads none.
InferOptions at_maturity(const InferOptions& io, const model::GeneratorFile& g, double maturity) {
  if (g.g->options().in_channels != model::kLabelAndMaturityChannels || maturity == 1) return io;
  InferOptions o = io;
  o.maturity = maturity;
  return o;
}
}  // namespace

EvalResult evaluate(model::GeneratorFile& g, const std::vector<EvalPair>& pairs, const EvalOptions& o) {
  const size_t n = pairs.size();
  std::vector<DecodedSketch> clean;
  for (const auto& p : pairs) clean.push_back(decode_sketch(p.label_bgr, p.name));
  std::vector<Perturbation> kinds = {Perturbation::None};
  if (o.perturb)
    kinds.insert(kinds.end(), {Perturbation::Blur, Perturbation::Jpeg50, Perturbation::HueJitter, Perturbation::BrushNoise});
  InferOptions io;
  io.running_stats = o.running_stats;
  io.amplify = !o.raw;
  io.variation = 0;  // the network's own answer against its pairs, not a re-rolled island
  EvalResult r;
  r.metrics = json::object();
  std::vector<double> clean_mae(n);
  std::vector<cv::Mat1f> clean_pred;
  Progress progress("eval", n * kinds.size(), o.quiet);
  size_t done = 0;
  for (const auto kind : kinds) {
    MetricSums sums;
    for (size_t i = 0; i < n; ++i) {  // one at a time: progress, bounded memory
      const DecodedSketch sk = kind == Perturbation::None
                                   ? clean[i]
                                   : decode_sketch(perturb(pairs[i].label_bgr, kind, uint64_t(pairs[i].index)), pairs[i].name);
      const cv::Mat1f pred = infer_heights(g, {sk}, at_maturity(io, g, pairs[i].maturity))[0];
      const MetricSums m = pair_metrics(pred, pairs[i].truth_m, clean[i].label, g.range.lo_m, g.range.hi_m,
                                        o.world_size_m / pred.cols);
      sums.add(m);
      if (kind == Perturbation::None) {
        clean_mae[i] = m.abs_sum / double(m.pixels);
        clean_pred.push_back(pred);
      }
      progress.tick(++done);
    }
    r.metrics[perturbation_name(kind)] = sums.finish();
  }
  // Worst cases on clean sketches: label | truth | prediction.
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t x, size_t y) { return clean_mae[x] > clean_mae[y]; });
  r.worst = json::array();
  std::vector<cv::Mat> rows;
  for (size_t k = 0; k < std::min<size_t>(4, n); ++k) {
    const size_t i = order[k];
    r.worst.push_back({{"index", pairs[i].index}, {"label", pairs[i].name}, {"mae_m", std::round(clean_mae[i] * 1e4) / 1e4}});
    cv::Mat row;
    cv::hconcat(std::vector<cv::Mat>{pairs[i].label_bgr, render_preview(pairs[i].truth_m), render_preview(clean_pred[i])}, row);
    rows.push_back(row);
  }
  if (!rows.empty()) cv::vconcat(rows, r.worst_sheet);
  return r;
}

void write_eval_files(const std::filesystem::path& dir, const json& report, const cv::Mat& worst_sheet) {
  ensure_writable_dir(dir);
  write_json_atomic(dir / "eval.json", report);
  std::string md = "| sketches | MAE (m) | RMSE (m) | SSIM | slope W1 (°) | coastline agreement |\n|---|---|---|---|---|---|\n";
  const json& metrics = report.at("metrics");
  for (const Perturbation p : {Perturbation::None, Perturbation::Blur, Perturbation::Jpeg50, Perturbation::HueJitter,
                               Perturbation::BrushNoise}) {
    if (!metrics.contains(perturbation_name(p))) continue;
    const json& m = metrics.at(perturbation_name(p));
    char line[256];
    std::snprintf(line, sizeof line, "| %s | %.2f | %.2f | %.4f | %.3f | %.4f |\n", perturbation_name(p), m["mae_m"].get<double>(),
                  m["rmse_m"].get<double>(), m["ssim"].get<double>(), m["slope_w1_deg"].get<double>(),
                  m["coastline_agreement"].get<double>());
    md += line;
  }
  md += "\nClean sketches, per region:\n\n| region | MAE (m) | RMSE (m) | pixel share |\n|---|---|---|---|\n";
  for (const char* name : kRegionNames) {
    const json& r = metrics.at("clean").at("per_region").at(name);
    char line[160];
    std::snprintf(line, sizeof line, "| %s | %.2f | %.2f | %.3f |\n", name, r["mae_m"].get<double>(),
                  r["rmse_m"].get<double>(), r["pixel_share"].get<double>());
    md += line;
  }
  write_text_atomic(dir / "eval.md", md);
  if (!worst_sheet.empty()) write_png(dir / "worst.png", worst_sheet);
}

namespace {
double share(int64_t a, int64_t b) { return b ? double(a) / double(b) : std::nan(""); }
json num(double v) { return std::isfinite(v) ? json(std::round(v * 1e4) / 1e4) : json(nullptr); }
}  // namespace

SketchesResult evaluate_sketches(model::GeneratorFile& gen, const std::vector<std::filesystem::path>& files,
                                 double young_max, bool quiet) {
  if (!(young_max >= 0 && young_max <= 1)) throw Error("--young-max must be in [0, 1]");
  if (files.empty()) throw Error("eval-sketches: no sketches");
  SketchesResult out;
  out.per_sketch = json::array();
  SketchChecks total;
  std::vector<double> crests, boards;
  std::vector<cv::Mat> tiles;
  Progress progress("eval-sketches", files.size(), quiet);
  for (size_t i = 0; i < files.size(); ++i) {
    const DecodedSketch s = read_sketch(files[i]);
    const cv::Mat1f pred = infer_heights(gen, {s}, {})[0];
    const SketchChecks c = sketch_checks(pred, s, young_max);
    total.land_px += c.land_px;
    total.land_above_0 += c.land_above_0;
    total.abyss_px += c.abyss_px;
    total.abyss_below_0 += c.abyss_below_0;
    total.abyss_below_20 += c.abyss_below_20;
    if (std::isfinite(c.reef_crest_m)) crests.push_back(c.reef_crest_m);
    boards.push_back(c.checkerboard_m);
    double lo = 0, hi = 0;
    cv::minMaxLoc(pred, &lo, &hi);
    out.per_sketch.push_back({{"sketch", files[i].filename().string()},
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
  const double board_mean = std::accumulate(boards.begin(), boards.end(), 0.0) / double(boards.size());
  out.overall = {{"young_land_above_0", num(share(total.land_above_0, total.land_px))},
                 {"young_abyss_below_0", num(share(total.abyss_below_0, total.abyss_px))},
                 {"young_abyss_below_minus20", num(share(total.abyss_below_20, total.abyss_px))},
                 {"reef_crest_m_median", num(median(crests))},
                 {"checkerboard_m_mean", num(board_mean)},
                 {"checkerboard_m_max", num(*std::max_element(boards.begin(), boards.end()))}};
  // Two sketch|result tiles per row.
  std::vector<cv::Mat> rows;
  for (size_t i = 0; i < tiles.size(); i += 2) {
    cv::Mat right = i + 1 < tiles.size() ? tiles[i + 1] : cv::Mat(tiles[i].size(), tiles[i].type(), cv::Scalar::all(0));
    cv::Mat row;
    cv::hconcat(std::vector<cv::Mat>{tiles[i], right}, row);
    rows.push_back(row);
  }
  cv::vconcat(rows, out.grid);
  return out;
}

}  // namespace reefgen::infer
