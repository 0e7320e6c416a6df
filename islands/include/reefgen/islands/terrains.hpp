#pragma once
// Other island systems users compare reefgen with, on reefgen's
// conventions: metres, sea level 0, row 0 at the top, canvas [-1, 1]².
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reefgen/params_json.hpp"
#include "reefgen/labels.hpp"

namespace reefgen::islands {

// Wilbur-style island (Joe Wilbur's island-shaping recipe): fBm n spanned to
// [0, 1], s = n·exp(−(r/4)²) − r² on [−1, 1]², land height = peak·s^p where
// s ≥ 0. Below sea level the recipe has 0; we keep −s as a bathymetry
// (depth_m·(−s)/0.5, clamped at −depth_m) so the field also has shallows and
// open ocean for sketches and previews.
struct WilburParams {
  int size_px = 256;       // W, [16, 4096]
  int octaves = 6;         // fBm octaves, [1, 10]
  double frequency = 2.0;  // base fBm features per canvas half-width, (0, 64]
  double exponent = 3.0;   // p: higher = flatter lowlands, sharper peaks, (0, 10]
  double peak_m = 500.0;   // height of s = 1, (0, 1e4]
  double depth_m = 100.0;  // ocean floor depth, (0, 1e4]
};
template <class F>
void fields(WilburParams& p, F&& f) {  // the one field list (common/params_json.hpp)
  f("size_px", p.size_px, Range{16, 4096});
  f("octaves", p.octaves, Range{1, 10});
  f("frequency", p.frequency, Range{0, 64, true});
  f("exponent", p.exponent, Range{0, 10, true});
  f("peak_m", p.peak_m, Range{0, 1e4, true});
  f("depth_m", p.depth_m, Range{0, 1e4, true});
}
cv::Mat1f wilbur_height(const WilburParams& p, uint64_t seed);

// Bands that turn any height field into a five-region label sketch.
struct SketchBands {
  double beach_top_m = 8.0;      // land below this is beach, above is mountain, (0, 1e4]
  double lagoon_depth_m = 12.0;  // water shallower than this is lagoon, (0, 1e4]
  double reef_depth_m = 40.0;    // then reef down to this depth, deeper is abyss, > lagoon_depth_m
};
// Regions by height bands; subsidence λ uniform (the value channel).
Sketch height_to_sketch(const cv::Mat1f& height_m, double subsidence, const SketchBands& b = {});

}  // namespace reefgen::islands

namespace reefgen::islands {

// mapgen4-style island (redblobgames' mapgen4; Guerra, "Procedural Island
// Generation" I-II): Bridson Poisson-disk points plus boundary rings,
// Delaunay triangulation (OpenCV Subdiv2D), mountain peak seeds from a
// coarser second Poisson sampling, the paint map
//   e = (k_fbm·fBm + k_d·(0.75 − 2d²)) / 2,  d = Chebyshev distance from the centre,
// ridges R = n₁ + n₂, r = max(0, 1 − |R|) weighted by the nearness of a peak,
// s = saturate(5e), e ← max(e, min(3e, s·r)); e evaluated at the triangles'
// centroids (centroid-based Voronoi vertices), cells take their triangles'
// mean, drawn as mapgen4 draws its dual mesh (the low-poly look), then metres:
// land = peak_m·e, water = depth_m·e/0.5 (clamped at −depth_m).
struct Mapgen4Params {
  int size_px = 256;              // W, [16, 4096]
  double spacing = 0.05;          // Poisson radius, canvas half-widths, [0.01, 0.5]
  double mountain_spacing = 0.35; // Poisson radius of the peak seeds, [spacing, 2]
  double k_fbm = 1.0;             // weight of the noise in the paint map, [0, 4]
  double k_d = 1.0;               // weight of the island-shaping falloff, [0, 4]
  double frequency = 2.0;         // fBm features per canvas half-width, (0, 64]
  double peak_m = 500.0;          // height of e = 1, (0, 1e4]
  double depth_m = 100.0;         // ocean floor depth, (0, 1e4]
  std::string falloff = "chebyshev";  // distance d of the falloff: "chebyshev" (square coasts) or "euclidean" (round)
};
template <class F>
void fields(Mapgen4Params& p, F&& f) {  // mountain_spacing ≥ spacing is checked beside it
  f("size_px", p.size_px, Range{16, 4096});
  f("spacing", p.spacing, Range{0.01, 0.5});
  f("mountain_spacing", p.mountain_spacing, Range{0.01, 2});
  f("k_fbm", p.k_fbm, Range{0, 4});
  f("k_d", p.k_d, Range{0, 4});
  f("frequency", p.frequency, Range{0, 64, true});
  f("peak_m", p.peak_m, Range{0, 1e4, true});
  f("depth_m", p.depth_m, Range{0, 1e4, true});
  f("falloff", p.falloff, OneOf{{"chebyshev", "euclidean"}});
}
cv::Mat1f mapgen4_height(const Mapgen4Params& p, uint64_t seed);

// Bridson's Poisson-disk sampling in [-1, 1]² (minimum distance `radius`,
// 30 candidates per active point), deterministic in `seed`.
std::vector<cv::Point2d> poisson_disk(double radius, uint64_t seed);

}  // namespace reefgen::islands

namespace reefgen::islands {
// "mapgen4" or "wilbur" with default parameters at `size_px`; throws
// reefgen::Error naming the choices for anything else.
cv::Mat1f named_terrain(const std::string& kind, int size_px, uint64_t seed);

// The same with parameters from JSON (configs/terrains/*.json are these params
// serialised): every key optional, unknown keys and bad values throw
// reefgen::Error naming `origin` and the key. `size_px` overrides the JSON's when > 0.
cv::Mat1f configured_terrain(const std::string& kind, const nlohmann::json& params, const std::string& origin,
                             int size_px, uint64_t seed);
nlohmann::json to_json(const WilburParams& p);
nlohmann::json to_json(const Mapgen4Params& p);
}  // namespace reefgen::islands
