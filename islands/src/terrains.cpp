#include "reefgen/islands/terrains.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "reefgen/files.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/terrain/noise.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/params_json.hpp"

namespace reefgen::islands {

using terrain::GradientNoise2;
using terrain::NoiseTile;

cv::Mat1f wilbur_height(const WilburParams& p, uint64_t seed) {
  check_params(p, "wilbur", "configs/terrains/wilbur.json");
  const int W = p.size_px;
  const GradientNoise2 noise(derive_seed(seed, 0, "wilbur"));
  Rng rng(derive_seed(seed, 1, "wilbur-offset"));
  const float ox = float(rng.uniform(0, 256)), oy = float(rng.uniform(0, 256));
  cv::Mat1f n(W, W);
  for (int r = 0; r < W; ++r)
    for (int c = 0; c < W; ++c) {
      const double x = (c + 0.5) / W * 2 - 1, y = 1 - (r + 0.5) / W * 2;
      n(r, c) = noise.fbm(float(x * p.frequency) + ox, float(y * p.frequency) + oy, p.octaves);
    }
  double lo, hi;
  cv::minMaxLoc(n, &lo, &hi);
  const double span = hi > lo ? hi - lo : 1.0;  // "spanned to [0, 1]"
  cv::Mat1f h(W, W);
  for (int r = 0; r < W; ++r)
    for (int c = 0; c < W; ++c) {
      const double x = (c + 0.5) / W * 2 - 1, y = 1 - (r + 0.5) / W * 2;
      const double rad = std::hypot(x, y);
      const double s = (n(r, c) - lo) / span * std::exp(-(rad / 4) * (rad / 4)) - rad * rad;
      h(r, c) = s >= 0 ? float(p.peak_m * std::pow(s, p.exponent))
                       : float(std::max(-p.depth_m, p.depth_m * s / 0.5));
    }
  return h;
}

Sketch height_to_sketch(const cv::Mat1f& h, double subsidence, const SketchBands& b) {
  if (!(b.beach_top_m > 0 && b.lagoon_depth_m > 0 && b.reef_depth_m > b.lagoon_depth_m))
    throw Error("sketch bands: need beach_top_m > 0 and 0 < lagoon_depth_m < reef_depth_m");
  if (!(subsidence >= 0 && subsidence <= 1)) throw Error("sketch: subsidence must be in [0, 1]");
  Sketch s{cv::Mat1b(h.size()), cv::Mat1f(h.size(), float(subsidence))};
  for (int r = 0; r < h.rows; ++r)
    for (int c = 0; c < h.cols; ++c) {
      const float v = h(r, c);
      uint8_t region = kAbyss;
      if (v >= b.beach_top_m) region = kIsland;
      else if (v >= 0) region = kBeach;
      else if (v > -b.lagoon_depth_m) region = kLagoon;
      else if (v > -b.reef_depth_m) region = kReef;
      s.label(r, c) = region;
    }
  return s;
}

cv::Mat1f named_terrain(const std::string& kind, int size_px, uint64_t seed) {
  if (kind == "mapgen4") {
    Mapgen4Params p;
    p.size_px = size_px;
    return mapgen4_height(p, seed);
  }
  if (kind == "wilbur") {
    WilburParams p;
    p.size_px = size_px;
    return wilbur_height(p, seed);
  }
  throw Error("terrain '" + kind + "': use mapgen4 or wilbur");
}

nlohmann::json to_json(const WilburParams& p) { return params_json(p); }
nlohmann::json to_json(const Mapgen4Params& p) { return params_json(p); }

cv::Mat1f configured_terrain(const std::string& kind, const nlohmann::json& j, const std::string& origin, int size_px,
                             uint64_t seed) {
  // Parse errors name the file and key; the rest (a --size override, rules
  // between fields) gets the file's name in front.
  auto named = [&](auto&& run) {
    try {
      return run();
    } catch (const Error& e) {
      throw Error(origin + ": " + e.what());
    }
  };
  if (kind == "wilbur") {
    auto p = params_from_json<WilburParams>(j, origin, "configs/terrains/");
    if (size_px > 0) p.size_px = size_px;
    return named([&] { return wilbur_height(p, seed); });
  }
  if (kind == "mapgen4") {
    auto p = params_from_json<Mapgen4Params>(j, origin, "configs/terrains/");
    if (size_px > 0) p.size_px = size_px;
    return named([&] { return mapgen4_height(p, seed); });
  }
  throw Error("terrain '" + kind + "': use mapgen4 or wilbur");
}

}  // namespace reefgen::islands
