#include "reefgen/augment/dataset.hpp"

#include <algorithm>
#include <cmath>

#include "reefgen/io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/procgen/curves.hpp"
#include "reefgen/procgen/erosion.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/random_spec.hpp"
#include "reefgen/islands/terrains.hpp"
#include "reefgen/rng.hpp"

namespace reefgen::augment {

using nlohmann::json;

void to_json(json& j, const DatasetParams& p) {
  j = json{{"count", p.count},           {"size_px", p.size_px},         {"levels", p.levels},
           {"val_fraction", p.val_fraction}, {"test_fraction", p.test_fraction}, {"p_affine", p.p_affine},
           {"scale_min", p.scale_min},   {"scale_max", p.scale_max},     {"p_translate", p.p_translate},
           {"p_paste", p.p_paste},       {"paste_scale", p.paste_scale}, {"max_iou", p.max_iou},
           {"p_mapgen4", p.p_mapgen4},   {"p_wilbur", p.p_wilbur},
           {"continuous_subsidence", p.continuous_subsidence}, {"subsidence_min", p.subsidence_min},
           {"subsidence_max", p.subsidence_max}, {"whole_islands", p.whole_islands}, {"border_px", p.border_px},
           {"p_erosion", p.p_erosion}};
  procgen::to_json(j["erosion"], p.erosion);
}

DatasetParams dataset_params_from_json(const json& j, const std::string& origin) {
  if (!j.is_object()) throw Error(origin + ": the dataset config must be a JSON object");
  DatasetParams p;
  json known;
  to_json(known, p);
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (it.key() == "description" || it.key() == "erosion") continue;
    if (!known.contains(it.key())) throw Error(origin + ": unknown key \"" + it.key() + "\" in the dataset config");
    if (known[it.key()].is_boolean()) {
      if (!it->is_boolean()) throw Error(origin + ": " + it.key() + " must be true or false");
    } else if (!it->is_number()) {
      throw Error(origin + ": " + it.key() + " must be a number");
    }
  }
  auto num = [&](const char* k, double& v, double lo, double hi) {
    if (j.contains(k)) v = j[k].get<double>();
    if (!(v >= lo && v <= hi))
      throw Error(origin + ": " + k + " = " + std::to_string(v) + " is out of range; expected [" + std::to_string(lo) +
                  ", " + std::to_string(hi) + "]");
  };
  double count = double(p.count), size = p.size_px, levels = p.levels;
  num("count", count, 1, 1e8);
  num("size_px", size, 16, 4096);
  num("levels", levels, 1, 64);
  for (const auto& [k, v] : {std::pair<const char*, double>{"count", count}, {"size_px", size}, {"levels", levels}})
    if (v != std::floor(v)) throw Error(origin + ": " + k + " = " + j[k].dump() + " must be a whole number");
  p.count = static_cast<int64_t>(count);
  p.size_px = static_cast<int>(size);
  p.levels = static_cast<int>(levels);
  num("val_fraction", p.val_fraction, 0, 0.5);
  num("test_fraction", p.test_fraction, 0, 0.5);
  num("p_affine", p.p_affine, 0, 1);
  num("scale_min", p.scale_min, 1e-3, 4);
  num("scale_max", p.scale_max, p.scale_min, 4);
  num("p_translate", p.p_translate, 0, 1);
  num("p_paste", p.p_paste, 0, 1);
  num("paste_scale", p.paste_scale, 1e-3, 1);
  num("max_iou", p.max_iou, 0, 1);
  num("p_mapgen4", p.p_mapgen4, 0, 1);
  num("p_wilbur", p.p_wilbur, 0, 1 - p.p_mapgen4);
  if (j.contains("continuous_subsidence")) p.continuous_subsidence = j["continuous_subsidence"].get<bool>();
  if (j.contains("whole_islands")) p.whole_islands = j["whole_islands"].get<bool>();
  num("subsidence_min", p.subsidence_min, 0, 1);
  num("subsidence_max", p.subsidence_max, p.subsidence_min, 1);
  double border = p.border_px;
  num("border_px", border, 1, 64);
  if (border != std::floor(border)) throw Error(origin + ": border_px must be an integer");
  p.border_px = static_cast<int>(border);
  num("p_erosion", p.p_erosion, 0, 1);
  if (j.contains("erosion")) p.erosion = procgen::erosion_params_from_json(j["erosion"], origin);
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
  const procgen::ErosionParams* params = nullptr;
};

Pair render(procgen::IslandSpec spec, int W, const ErosionJob& e = {}) {
  procgen::RenderOptions o;
  o.size_px = W;
  spec.erosion = e.params ? *e.params : procgen::ErosionParams{};
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
  // Other island systems (issue 6) from their own RNG stream, so that the
  // pairs of datasets without them stay byte-identical.
  // Erosion and its seed from their own stream, for the same reason.
  ErosionJob erosion;
  if (p.p_erosion > 0) {
    Rng er(seed, static_cast<uint64_t>(index), "erosion");
    if (er.uniform() < p.p_erosion) {
      erosion = {&p.erosion};
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
  info.augmentation = aug;
  if (out_info) *out_info = info;
  return pair;
}

}  // namespace reefgen::augment
