#pragma once
// Everything that defines one island (the paper's Figure 3 inputs), with the
// defaults of docs/DESIGN.md §3. configs/presets/*.json are serialised IslandSpecs;
// docs/SPEC.md documents the JSON schema.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/procgen/curves.hpp"
#include "reefgen/params_json.hpp"
#include "reefgen/terrain/erosion.hpp"

namespace reefgen::procgen {

inline constexpr int kNumOutlines = 5;  // outer borders of island, beach, lagoon, reef, abyss

// Default profile h*(u) and resistance ρ*(u), 30 samples on u = x̃/5 ∈ [0,1].
std::vector<double> default_profile();
std::vector<double> default_resistance();

// Points as [x, y] in JSON, 2..1024 of them, each coordinate in [-4, 4].
nlohmann::json points_to_json(const std::vector<Vec2>& points);
void points_from_json(const nlohmann::json& j, std::vector<Vec2>& points, const std::string& where);
void check_points(const std::vector<Vec2>& points, const std::string& where);

struct WindStroke {
  std::vector<Vec2> points;  // canvas units in [-4,4]² (+y up), 2..1024 control points of an open Catmull-Rom curve
  double strength = 0.2;     // canvas units, peak displacement S, [0, 2]
  double width = 0.2;        // canvas units, Gaussian σ, [0.005, 2]
};
template <class F>
void fields(WindStroke& w, F&& f) {  // the one field list (common/params_json.hpp)
  f("points", w.points, Custom<std::vector<Vec2>>{points_to_json, points_from_json, check_points});
  f("strength", w.strength, Range{0, 2});
  f("width", w.width, Range{0.005, 2});
}

// Monotone piecewise-linear map M from the normalised profile space to metres.
struct HeightMapping {
  double floor_m = -100;    // m, M(0), the abyss floor, [-11000, -1]
  double sea_level = 0.4;   // normalised profile value mapped to 0 m, (0, 1)
  double peak_m = 500;      // m, M(1), [1, 9000]
};
template <class F>
void fields(HeightMapping& p, F&& f) {  // the one field list (common/params_json.hpp)
  f("floor_m", p.floor_m, Range{-11000, -1});
  f("sea_level", p.sea_level, Range{1e-3, 1 - 1e-3});
  f("peak_m", p.peak_m, Range{1, 9000});
}

// Coral height field over x = x̃ − 3 (Eqs. 6-8).
struct CoralParams {
  bool enabled = true;
  double back_m = -20;       // m, back reef / lagoon floor for x ≤ back_end
  double crest_m = -2;       // m, reef crest on [crest_begin, crest_end]
  double abyss_m = -100;     // m, fore-reef foot for x ≥ 1
  double back_end = 0.5;     // x where the rise to the crest starts, [0, crest_begin]
  double crest_begin = 0.75; // x, [back_end, crest_end]
  double crest_end = 0.8;    // x, [crest_begin, 1]
};
template <class F>
void fields(CoralParams& p, F&& f) {  // back_end ≤ crest_begin ≤ crest_end is checked by validate()
  f("enabled", p.enabled);
  f("back_m", p.back_m, Range{-11000, 9000});
  f("crest_m", p.crest_m, Range{-11000, 9000});
  f("abyss_m", p.abyss_m, Range{-11000, 9000});
  f("back_end", p.back_end, Range{0, 1});
  f("crest_begin", p.crest_begin, Range{0, 1});
  f("crest_end", p.crest_end, Range{0, 1});
}

// Multiplicative surface noise on the volcano heights (signed metres, so the
// 0 m coastline of the profile is kept exactly where the outlines put it).
struct DetailNoise {
  double amplitude = 0.1;   // fraction of |h|, [0, 0.5]; 0 switches it off
  double feature = 0.04;    // canvas units per noise feature (0.04 = W/50 px), [0.005, 1]
  int octaves = 3;          // fBm octaves, [1, 4]
  uint64_t seed = 0;        // noise seed (random islands derive it from the global seed)
};
template <class F>
void fields(DetailNoise& p, F&& f) {
  f("amplitude", p.amplitude, Range{0, 0.5});
  f("feature", p.feature, Range{0.005, 1});
  f("octaves", p.octaves, Range{1, 4});
  f("seed", p.seed);
}

// Control radii of R_1..R_5 (outer borders of regions 0..4), canvas units,
// evenly spaced in θ from +x counter-clockwise; 1 value = circle. Each in
// [1e-3, 3], 1..4096 per outline. JSON: an array of 5, each a radius or an
// array of radii.
using Outlines = std::array<std::vector<double>, kNumOutlines>;
nlohmann::json outlines_to_json(const Outlines& o);
void outlines_from_json(const nlohmann::json& j, Outlines& o, const std::string& where);
void check_outlines(const Outlines& o, const std::string& where);

struct IslandSpec {
  std::string description;                        // free text, shown by `reefgen presets`
  Outlines outlines{
      std::vector<double>{0.3}, std::vector<double>{0.38}, std::vector<double>{0.55},
      std::vector<double>{0.68}, std::vector<double>{0.98}};
  double min_gap = 0.02;                          // canvas units, δ: R_{i+1} ≥ R_i + δ, [0.001, 0.2]
  std::vector<double> profile = default_profile();        // normalised heights on u ∈ [0,1], each in [0,1], ≥ 2 samples
  std::vector<double> resistance = default_resistance();  // ρ on u ∈ [0,1], each in [0,1], ≥ 2 samples
  std::vector<WindStroke> wind;                    // 0..64 strokes
  int wind_substeps = 10;                          // semi-Lagrangian sub-steps, [1, 100]
  double subsidence = 0;                           // λ, [0, 1]: 0 young volcano, 1 atoll
  HeightMapping heights;
  CoralParams coral;
  double smax_k = 0.5;                             // 1/m, smooth-max sharpness (overshoot ≤ 1/(2k) m), [0.01, 100]
  DetailNoise noise;
  terrain::ErosionParams erosion;                           // fluvial erosion of the land before coral growth (docs/EROSION.md)
  double world_size_m = kCanvasWorldSizeM;        // m, width of the [-1,1] canvas, [10, 1e6]
};
// The one field list (common/params_json.hpp); the rules between fields
// (coral's back_end ≤ crest_begin ≤ crest_end) are validate()'s.
template <class F>
void fields(IslandSpec& s, F&& f) {
  f("description", s.description);
  f("outlines", s.outlines, Custom<Outlines>{outlines_to_json, outlines_from_json, check_outlines});
  f("min_gap", s.min_gap, Range{0.001, 0.2});
  f("profile", s.profile, Range{0, 1}, Count{2, 4096});
  f("resistance", s.resistance, Range{0, 1}, Count{2, 4096});
  f("wind", s.wind, Count{0, 64});
  f("wind_substeps", s.wind_substeps, Range{1, 100});
  f("subsidence", s.subsidence, Range{0, 1});
  f("heights", s.heights);
  f("coral", s.coral);
  f("smax_k", s.smax_k, Range{0.01, 100});
  f("noise", s.noise);
  f("erosion", s.erosion);
  f("world_size_m", s.world_size_m, Range{10, 1e6});
}

// Throws reefgen::Error naming the first invalid field and its valid range.
void validate(const IslandSpec& spec);

// JSON (the field walk): every field optional (defaults above); unknown keys
// are rejected so a typo does not silently fall back to a default.
void to_json(nlohmann::json& j, const IslandSpec& s);
void from_json(const nlohmann::json& j, IslandSpec& s);
// Parses and validates; errors name `origin` (a file name) and the field.
IslandSpec spec_from_json(const nlohmann::json& j, const std::string& origin);

}  // namespace reefgen::procgen
