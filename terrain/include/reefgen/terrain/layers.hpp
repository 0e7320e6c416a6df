#pragma once
// The layers a terrain artist textures with, beside the heights
// (docs/LAYERS.md): drainage area (flow), slope, the erosion's wear and
// deposit, normals, and the weights of eight named materials derived from
// the regions (painted or generated), height, slope, flow and deposits.
// Weights sum to 1 at every pixel by construction. Deterministic: the rows
// a function's `threads` share are independent, so the bytes are the same
// whatever the thread count.
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reefgen/params_json.hpp"

namespace reefgen::terrain {

// Splat order: splat0 RGBA = the first four, splat1 RGBA = the last four.
enum Material : int {
  kDeepSeaFloor = 0,
  kLagoonSand,
  kReefCover,
  kBeachSand,
  kVegetation,
  kRockCliff,
  kScree,
  kRiverbed,
  kNumMaterials
};
// "deep_sea_floor", "lagoon_sand", "reef", "beach_sand", "vegetation", "rock_cliff", "scree", "riverbed".
const char* material_name(int material);
// A material's base colour, RGB 0…255 (the materials map's palette: sand
// seen through shallow water, reef, deep floor…).
const float* material_rgb(int material);

// The material rules (docs/LAYERS.md). Each rule is a smooth step between
// a start and a full value, so materials blend instead of switching at a pixel.
struct LayerParams {
  double region_blend_m = 40;      // Gaussian σ over which painted regions blend, m, [0, 2000]
  double deep_sea_m = 40;          // water this deep (and more) is deep sea floor wherever painted, m, [1, 2000]
  double beach_top_m = 3;          // land below this is beach sand (full below half of it), m, [0, 100]
  double cliff_deg = 45;           // slope where rock shows half (full 6° steeper), degrees, [5, 89]
  double scree_deg = 34;           // slope where scree lies half (full 4° steeper), degrees, [1, 89]
  double scree_deposit_m = 0.5;    // deposit on a slope of ≥ 10° that is full scree (talus at slope feet), m, [0.01, 100]
  double river_area_m2 = 1e5;      // drainage area where a riverbed starts (full at ×10), m², [1, 1e12]
  double settle_deg = 12;          // eroded material settles on slopes gentler than this (deposit layer), degrees, [0.1, 89]
};

template <class F>
void fields(LayerParams& p, F&& f) {
  f("region_blend_m", p.region_blend_m, Range{0, 2000});
  f("deep_sea_m", p.deep_sea_m, Range{1, 2000});
  f("beach_top_m", p.beach_top_m, Range{0, 100});
  f("cliff_deg", p.cliff_deg, Range{5, 89});
  f("scree_deg", p.scree_deg, Range{1, 89});
  f("scree_deposit_m", p.scree_deposit_m, Range{0.01, 100});
  f("river_area_m2", p.river_area_m2, Range{1, 1e12});
  f("settle_deg", p.settle_deg, Range{0.1, 89});
}
void to_json(nlohmann::json& j, const LayerParams& p);
// Every key optional; unknown keys and out-of-range values throw reefgen::Error naming `origin`.
LayerParams layer_params_from_json(const nlohmann::json& j, const std::string& origin);

struct Layers {
  cv::Mat1f flow_area_m2;  // drainage area through each land cell (Priority-Flood, Quinn's shared flow); sea 0
  cv::Mat1f slope_deg;     // steepest slope, degrees, [0, 90)
  cv::Mat1f wear_m;        // metres the erosion removed (≥ 0)
  cv::Mat1f deposit_m;     // metres laid down (≥ 0): basins the erosion filled, plus where the worn material settles (slope feet, valley floors)
  cv::Mat3f normal;        // unit normals (x east, y north, z up)
  std::array<cv::Mat1f, kNumMaterials> weight;  // per material, [0, 1], summing to 1 at every pixel
};

// What the material rules read at one pixel.
struct PixelFacts {
  float height_m, slope_deg, flow_area_m2, deposit_m;
  float abyss, reef, beach;  // the painted regions' blended shares, [0, 1]
};
// The eight material weights of one pixel (docs/LAYERS.md), summing to 1.
void material_weights(const PixelFacts& f, const LayerParams& p, float w[kNumMaterials]);

// height_m: the finished heights (sea level 0, row 0 north); before_m: the
// same field before erosion (same size; empty = no erosion: wear and
// deposit 0); region: region ids 0..4 (labels.hpp) at the same size, or
// empty (then read from the heights: regions_of_heights).
// threads: rows of the per-pixel maps shared out (same bytes whatever the count).
Layers compute_layers(const cv::Mat1f& height_m, const cv::Mat1f& before_m, const cv::Mat1b& region,
                      double metres_per_px, const LayerParams& p = {}, int threads = 1);

// Regions where only heights are known (a user's heightmap): land is island
// (beach below beach_top_m), water is lagoon down to 10 m, reef cover from
// there to 30 m, abyss below.
cv::Mat1b regions_of_heights(const cv::Mat1f& height_m, const LayerParams& p = {});

// Weights quantised to 8 bits, summing to exactly 255 at every pixel
// (largest remainder), packed four materials per RGBA image.
std::array<cv::Mat4b, 2> splat_maps(const Layers& layers);

// A colour picture of the materials (each its base colour), BGR: hill-shaded
// for the picture docs/ shows and PREFIX.materials.png; unshaded (the
// normals are used only when shaded) for textures an engine lights itself.
cv::Mat3b material_colour_map(const Layers& layers, bool shaded = true);
// A picture of the drainage (BGR): the relief hill-shaded in grey, water
// blue, and the flow drawn over it from white (a few cells drain here) to
// deep blue (the largest drainage area on the map), on a log scale.
cv::Mat3b flow_colour_map(const Layers& layers, const cv::Mat1f& height_m, double metres_per_px);
// A picture of the rain (BGR, rain_mm_yr at the heights' size): the land
// hill-shaded and tinted from dry ochre (the map's driest land) to wet
// blue-green (its wettest), a linear scale between the two; the sea blue.
cv::Mat3b rain_colour_map(const Layers& layers, const cv::Mat1f& height_m, const cv::Mat1f& rain_mm_yr);

}  // namespace reefgen::terrain

namespace reefgen {
class StagedOutputs;
}

namespace reefgen::terrain {

// The largest drainage area (m²), wear and deposit (m) the layer files encode.
struct LayerScales {
  double flow_area_m2 = 0, wear_m = 0, deposit_m = 0;
  // The encodings' full values: log10 of the largest area in cells (at least
  // one cell's), and wear and deposit of at least kMinScaleM (an all-zero
  // layer still gets a scale).
  static constexpr double kMinScaleM = 0.01;
  double flow_log10_max(double metres_per_px) const {
    const double cell = metres_per_px * metres_per_px;
    return std::max(1e-6, std::log10(std::max(flow_area_m2, cell) / cell));
  }
  double wear_scale_m() const { return std::max(wear_m, kMinScaleM); }
  double deposit_scale_m() const { return std::max(deposit_m, kMinScaleM); }
};

// Stages the layer files of PREFIX (nothing is in place before
// staged.commit()) and returns what the sidecar says about them: each
// file, its encoding and scale, the materials in splat order, the rules.
//   PREFIX.flow.png      16-bit, log-encoded drainage area (scale in the sidecar)
//   PREFIX.slope.png     8-bit, degrees · 255/90
//   PREFIX.wear.png, PREFIX.deposit.png   8-bit, metres · 255/scale_m
//   PREFIX.normal.png    RGB8, OpenGL convention (green = north / +Y)
//   PREFIX.splat0.png, PREFIX.splat1.png  RGBA8, four material weights each, summing to 255
//   PREFIX.materials.png RGB8 colour map (materials hill-shaded)
// The files are prepared and encoded on `threads` threads (same bytes
// whatever the count).
// scales: the flow, wear and deposit encodings' full values; null = this
// field's own maxima (tiles of one world share the world's instead).
nlohmann::json stage_layer_files(StagedOutputs& staged, const std::string& prefix, const Layers& layers,
                                 double metres_per_px, const LayerParams& params, int threads = 1,
                                 const LayerScales* scales = nullptr);

// {kind: file name} of PREFIX's layer files (flow, slope, …, materials).
nlohmann::json layer_file_names(const std::string& prefix);
// What the sidecar says about layer files encoded with `scales` (all but the files).
nlohmann::json layer_files_description(double metres_per_px, const LayerParams& params, const LayerScales& scales);

// Puts what stage_layer_files returned into an island's sidecar: its files
// beside the others under "files", the rest under "layers".
void add_layers_to_sidecar(nlohmann::json& sidecar, nlohmann::json layers);

// The rain the erosion read, beside the layers where there was a wind
// (docs/LAYERS.md): PREFIX + kRainFileSuffix, float32 EXR in mm/yr.
inline constexpr const char* kRainFileSuffix = ".rain.exr";
// Stages that file; returns its size in bytes (the sidecar's file_bytes).
uint64_t stage_rain_file(StagedOutputs& staged, const std::string& prefix, const cv::Mat1f& rain_mm_yr,
                         double metres_per_px);

// The suffixes stage_layer_files writes (for output-over-input checks).
std::vector<std::string> layer_file_suffixes();

}  // namespace reefgen::terrain
