#include "reefgen/augment/dataset.hpp"

#include <algorithm>
#include <cmath>

#include "reefgen/age.hpp"
#include "reefgen/files.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/procgen/curves.hpp"
#include "reefgen/terrain/erosion.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/random_spec.hpp"
#include "reefgen/procgen/reef.hpp"
#include "reefgen/islands/terrains.hpp"
#include "reefgen/rng.hpp"

namespace reefgen::augment {

using nlohmann::json;

namespace {
// The youngest age a log-uniform draw starts at, My.
constexpr double kMinDrawnAgeMyr = 1e-4;
}  // namespace

void to_json(json& j, const DatasetParams& p) { j = params_json(p); }

DatasetParams dataset_params_from_json(const json& j, const std::string& origin) {
  const DatasetParams p = params_from_json<DatasetParams>(j, origin, "docs/DATASET.md", "", {"description"});
  auto order = [&](const char* lo_key, double lo, const char* hi_key, double hi) {
    if (!(hi >= lo))
      throw Error(origin + ": " + hi_key + " = " + std::to_string(hi) + " is below " + lo_key + " = " + std::to_string(lo));
  };
  order("scale_min", p.scale_min, "scale_max", p.scale_max);
  order("subsidence_min", p.subsidence_min, "subsidence_max", p.subsidence_max);
  order("maturity_min", p.maturity_min, "maturity_max", p.maturity_max);
  if (p.age_min_myr != kNotSet || p.age_max_myr != kNotSet) {
    if (!(p.age_min_myr >= 0)) throw Error(origin + ": age_min_myr must be in [0, 60] when age_max_myr is set (-1 for no ages)");
    order("age_min_myr", p.age_min_myr, "age_max_myr", p.age_max_myr);
  }
  if (p.p_mapgen4 + p.p_wilbur > 1)
    throw Error(origin + ": p_wilbur = " + std::to_string(p.p_wilbur) + " and p_mapgen4 = " + std::to_string(p.p_mapgen4) +
                " add up to more than 1");
  return p;
}

const char* split_name(Split s) {
  switch (s) {
    case Split::kTrain: return "train";
    case Split::kVal: return "val";
    default: return "test";
  }
}

Split split_of(uint64_t seed, int64_t configuration, const DatasetParams& p) {
  const double u = Rng(seed, static_cast<uint64_t>(configuration), "split").uniform();
  if (u < p.test_fraction) return Split::kTest;
  if (u < p.test_fraction + p.val_fraction) return Split::kVal;
  return Split::kTrain;
}

PairInfo pair_info(uint64_t seed, int64_t index, const DatasetParams& p) {
  PairInfo info;
  info.index = index;
  info.configuration = index / p.levels;
  info.level = static_cast<int>(index % p.levels);
  info.subsidence = procgen::subsidence_levels(p.levels)[info.level];
  if (p.continuous_subsidence)  // own stream: the other draws of a pair do not move
    info.subsidence = Rng(seed, static_cast<uint64_t>(index), "subsidence").uniform(p.subsidence_min, p.subsidence_max);
  info.split = split_of(seed, info.configuration, p);
  info.seed = procgen::random_spec(seed, static_cast<uint64_t>(info.configuration)).noise.seed;
  // Age and maturity from their own stream (log-uniform: a young shield and
  // Kauaʻi's age as likely per factor of time); none drawn by default.
  const auto log_uniform = [&](const char* stream, double lo, double hi) {
    return lo * std::exp(Rng(seed, static_cast<uint64_t>(index), stream).uniform() * std::log(hi / lo));
  };
  if (p.age_min_myr >= 0) {
    // An age of 0 has no logarithm: the draw starts at a tenth of a millennium.
    info.age_myr = log_uniform("age", std::max(p.age_min_myr, kMinDrawnAgeMyr), std::max(p.age_max_myr, kMinDrawnAgeMyr));
    info.subsidence = subsidence_of_age(info.age_myr);
    info.maturity = maturity_of_age(info.age_myr);
  } else if (p.maturity_min < p.maturity_max) {
    info.maturity = log_uniform("maturity", p.maturity_min, p.maturity_max);
  } else {
    info.maturity = p.maturity_min;
  }
  return info;
}

bool border_is_abyss(const cv::Mat1b& label, int border_px) {
  const int W = label.cols, H = label.rows, b = std::min({border_px, W / 2, H / 2});
  for (int y = 0; y < H; ++y) {
    const uint8_t* row = label.ptr<uint8_t>(y);
    const bool edge_row = y < b || y >= H - b;
    for (int x = 0; x < W; ++x)
      if ((edge_row || x < b || x >= W - b) && row[x] != kAbyss) return false;
  }
  return true;
}

namespace {
// Erosion of a render: the dataset's params (docs/EROSION.md) or none.
struct ErosionJob {
  const terrain::ErosionParams* params = nullptr;
};

Pair render(procgen::IslandSpec spec, int W, const ErosionJob& e = {}) {
  procgen::RenderOptions o;
  o.size_px = W;
  spec.erosion = e.params ? *e.params : terrain::ErosionParams{};
  spec.erosion.enabled = e.params != nullptr && e.params->enabled;
  auto f = procgen::generate(spec, o);
  return {f.height_m, f.label, cv::Mat1f(W, W, static_cast<float>(spec.subsidence))};
}

// An island rendered at scale·W and centred on a W×W ocean: the same as
// shrinking a full render, sharper, and 1/scale² cheaper.
Pair render_scaled(const procgen::IslandSpec& spec, int W, double scale, const ErosionJob& e = {}) {
  const int w = std::max(8, static_cast<int>(std::lround(W * scale)));
  if (w >= W) return render(spec, W, e);
  const Pair small = render(spec, w, e);
  Pair out{cv::Mat1f(W, W, -100.f), cv::Mat1b(W, W, uint8_t(kAbyss)),
           cv::Mat1f(W, W, static_cast<float>(spec.subsidence))};
  const cv::Rect r((W - w) / 2, (W - w) / 2, w, w);
  small.height_m.copyTo(out.height_m(r));
  small.label.copyTo(out.label(r));
  return out;
}
}  // namespace

Pair make_pair(uint64_t seed, int64_t index, const DatasetParams& p, PairInfo* out_info) {
  PairInfo info = pair_info(seed, index, p);
  Rng rng(seed, static_cast<uint64_t>(index), "augmentation");
  auto spec = procgen::random_spec(seed, static_cast<uint64_t>(info.configuration));
  spec.subsidence = info.subsidence;
  json aug = json::object();
  // Draw every decision up front, in a fixed order, so that the RNG stream
  // does not depend on which branches run.
  const bool do_paste = rng.uniform() < p.p_paste;
  const int extra = 1 + static_cast<int>(rng.uniform_int(0, 1));
  const uint64_t paste_seed = rng.next_u64();
  const bool do_affine = rng.uniform() < p.p_affine;
  const double angle = rng.uniform(0, 360), scale = rng.uniform(p.scale_min, p.scale_max);
  const bool flip = rng.uniform() < 0.5;
  const bool do_translate = rng.uniform() < p.p_translate;
  const int dx = static_cast<int>(rng.uniform_int(0, p.size_px - 1)), dy = static_cast<int>(rng.uniform_int(0, p.size_px - 1));
  // Other island systems from their own RNG stream, so that the
  // pairs of datasets without them stay byte-identical.
  // Erosion and its seed from their own stream, for the same reason.
  ErosionJob erosion;
  const terrain::ErosionParams matured = info.maturity == 1 ? p.erosion : terrain::matured(p.erosion, info.maturity);
  if (p.p_erosion > 0) {
    Rng er(seed, static_cast<uint64_t>(index), "erosion");
    if (er.uniform() < p.p_erosion) {
      erosion = {&matured};
      aug["erosion"] = true;
    }
  }
  std::string source = "curves";
  if (p.p_mapgen4 + p.p_wilbur > 0) {
    Rng src(seed, static_cast<uint64_t>(index), "source");
    const double u = src.uniform();
    if (u < p.p_mapgen4) source = "mapgen4";
    else if (u < p.p_mapgen4 + p.p_wilbur) source = "wilbur";
  }
  Pair pair;
  if (source != "curves") {
    // A young island (λ = 0) of the other system, its label cut by height bands.
    const cv::Mat1f h = islands::named_terrain(source, p.size_px, derive_seed(seed, static_cast<uint64_t>(index), source));
    pair = {h, islands::height_to_sketch(h, 0.0).label, cv::Mat1f(h.size(), 0.0f)};
    info.subsidence = 0.0;
    aug["source"] = source;
  } else if (!do_paste) {
    pair = render(spec, p.size_px, erosion);
  } else {
    // Companions are sub-configurations of the same configuration, so a pasted
    // island never leaks across splits.
    std::vector<Pair> islands = {render_scaled(spec, p.size_px, p.paste_scale, erosion)};
    for (int k = 0; k < extra; ++k) {
      auto s = procgen::random_spec(seed ^ 0xC0FFEEull, static_cast<uint64_t>(info.configuration) * 8 + k);
      s.subsidence = info.subsidence;
      Pair companion = render_scaled(s, p.size_px, p.paste_scale, erosion);
      // A companion is moved by a wrap-around shift: it must be whole.
      if (p.whole_islands && !border_is_abyss(companion.label, p.border_px)) continue;
      islands.push_back(std::move(companion));
    }
    const auto r = copy_paste(islands, paste_seed, p.max_iou);
    pair = r.pair;
    aug["paste"] = {{"islands", r.placed}, {"scale", p.paste_scale}};
  }
  if (do_affine) {
    pair = affine(pair, angle, scale, flip);
    aug["affine"] = {{"angle_deg", angle}, {"scale", scale}, {"flip_x", flip}};
  }
  if (do_translate) {
    if (p.whole_islands && !border_is_abyss(pair.label, p.border_px)) {
      aug["translate_skipped"] = "island touches the canvas edge";
    } else {
      pair = translate_wrap(pair, dx, dy);
      aug["translate"] = {dx, dy};
    }
  }
  if (p.redraw_flank && source == "curves") {
    FlankShape f;
    f.metres_per_px = spec.world_size_m / p.size_px;
    f.floor_m = spec.heights.floor_m;
    f.foot_m = spec.reef.enabled ? -procgen::rim_edge_depth_m(spec.reef) : spec.coral.abyss_m;
    f.decay_m = spec.reef.abyss_decay_m;
    f.relief_m = spec.reef.abyss_relief_m;
    pair = redraw_flank(pair, f, derive_seed(seed, static_cast<uint64_t>(index), "flank"));
    aug["flank_redrawn"] = true;
  }
  info.augmentation = aug;
  if (out_info) *out_info = info;
  return pair;
}

}  // namespace reefgen::augment
