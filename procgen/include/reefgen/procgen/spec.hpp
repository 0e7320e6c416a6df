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
#include "reefgen/terrain/rain.hpp"

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

// Coral height field over x = x̃ − 3 (Eqs. 6-8), with a reef flat between
// the back reef and the crest. Living crests grow to the surface and dry at
// low tide; the flat behind them lies 0…−2 m (docs/REEF.md).
struct CoralParams {
  bool enabled = true;
  double back_m = -20;       // m, back-reef toe for x ≤ back_end (with reef.enabled: the lagoon floor instead)
  double flat_m = -0.8;      // m, reef flat on [flat_begin, crest_begin], [-11000, 9000]
  double crest_m = -0.3;     // m, reef crest on [crest_begin, crest_end] (awash: dries at low tide)
  double abyss_m = -80;      // m, fore-reef foot for x ≥ 1
  double back_end = 0.4;     // x where the rise to the reef flat starts, [0, flat_begin]
  double flat_begin = 0.55;  // x, [back_end, crest_begin]
  double crest_begin = 0.75; // x, [flat_begin, crest_end]
  double crest_end = 0.8;    // x, [crest_begin, 1]
};
template <class F>
void fields(CoralParams& p, F&& f) {  // back_end ≤ flat_begin ≤ crest_begin ≤ crest_end is checked by validate()
  f("enabled", p.enabled);
  f("back_m", p.back_m, Range{-11000, 9000});
  f("flat_m", p.flat_m, Range{-11000, 9000});
  f("crest_m", p.crest_m, Range{-11000, 9000});
  f("abyss_m", p.abyss_m, Range{-11000, 9000});
  f("back_end", p.back_end, Range{0, 1});
  f("flat_begin", p.flat_begin, Range{0, 1});
  f("crest_begin", p.crest_begin, Range{0, 1});
  f("crest_end", p.crest_end, Range{0, 1});
}

// Points of all drawn passes together, at most: each cell of the reef looks
// at the passes near it, and this bounds that look-up (a drawn curve is
// sampled finer only while it has few points).
inline constexpr int kMaxPassPoints = 4096;

// A pass through the reef rim: a curve the rim is cut along (the authors'
// tool draws them as curves), with its width and floor depth.
struct PassStroke {
  std::vector<Vec2> points;  // canvas units in [-4,4]² (+y up), 2..1024 points of an open Catmull-Rom curve
  double width_m = 150;      // m, full width of the channel (real passes: tens of metres to ~1 km), [10, 1000]
  double depth_m = 12;       // m, floor of the pass below sea level, [1, 80]
};
template <class F>
void fields(PassStroke& p, F&& f) {
  f("points", p.points, Custom<std::vector<Vec2>>{points_to_json, points_from_json, check_points});
  f("width_m", p.width_m, Range{10, 1000});
  f("depth_m", p.depth_m, Range{1, 80});
}

// A motu: a low sand islet on the reef flat, centred at an angle from the
// canvas centre, elongated along the rim.
struct Motu {
  double angle_deg = 0;    // degrees counter-clockwise from +x, [-360, 360]
  double length_m = 600;   // m, along the rim, [30, 20000]
  double width_m = 260;    // m, across the rim, [30, 3000]
  double height_m = 2.5;   // m above sea level at its crown, [0.5, 8]
};
template <class F>
void fields(Motu& m, F&& f) {
  f("angle_deg", m.angle_deg, Range{-360, 360});
  f("length_m", m.length_m, Range{30, 20000});
  f("width_m", m.width_m, Range{30, 3000});
  f("height_m", m.height_m, Range{0.5, 8});
}

// Reef geomorphology (docs/REEF.md): a lagoon that is water at every age,
// basins deeper than the rim, patch reefs, passes, motu, spur-and-groove and
// a sea floor with relief. enabled = false gives the paper's Eqs. 6–9 alone.
struct ReefParams {
  bool enabled = true;
  double lagoon_depth_m = 0;         // m, deepest lagoon floor of a sunk island; 0 = from the lagoon's area, [0, 150]
  double young_lagoon_share = 0.2;   // share of that depth at subsidence 0 (a fringing back-reef), [0, 1]
  double coast_begin = 1.4;          // x̃ where the land starts its descent to the lagoon shore at x̃ = 2, [1, 1.95]
  double shoreface = 0.3;            // x̃ units over which the lagoon shore descends to the floor, [0.02, 1]
  double patch_reefs = 0.3;          // how much of the lagoon floor rises in patch reefs (0 none, 1 about a third), [0, 1]
  std::vector<PassStroke> passes;    // drawn passes, 0..64, kMaxPassPoints points in all
  int random_passes = 2;             // passes added on the leeward rim, [0, 16]
  std::vector<Motu> motu;            // placed motu, 0..256
  int random_motu = 6;               // motu added on the reef flat (scaled down below subsidence 0.2), [0, 64]
  double groove_spacing_m = 70;      // m, spur-and-groove period along the windward fore reef (Storlazzi et al. 2003: 71 m at 5 m depth), [5, 200]
  double groove_amplitude_m = 1.5;   // m, spur top to groove floor / 2, [0, 10]
  double groove_depth_m = 20;        // m, grooves run from the crest down to this depth, [2, 60]
  double flat_width_m = 500;         // m, reef flat from the crest towards the lagoon where the rim is wide enough (Johnson & Ortiz 2023: 850 ± 817 m on 154 atolls), [0, 5000]
  double windward_flat_gain = 0.3;   // flat width × (1 + gain · cos of the angle from windward): wider where the waves come from, [0, 0.9]
  double crest_width_m = 30;         // m, the reef crest between the flat and the fore reef, [5, 300]
  double fore_reef_m = 130;          // m, the fore-reef terrace from the crest down to fore_reef_depth_m (One Tree Reef: 3° over 137 m), [20, 1000]
  double fore_reef_depth_m = 20;     // m, depth of the fore-reef terrace's foot, where the drop-off begins (60 m further out the rim ends at −60 m), [2, 60]
  double abyss_decay_m = 35;         // m, horizontal scale of the flank's fall beyond the rim's −60 m edge (35: 40° at its top; flank_height_m), [10, 1e5]
  double abyss_relief_m = 4;         // m, sea-floor relief (low-frequency noise), [0, 30]
};
template <class F>
void fields(ReefParams& p, F&& f) {
  f("enabled", p.enabled);
  f("lagoon_depth_m", p.lagoon_depth_m, Range{0, 150});
  f("young_lagoon_share", p.young_lagoon_share, Range{0, 1});
  f("coast_begin", p.coast_begin, Range{1, 1.95});
  f("shoreface", p.shoreface, Range{0.02, 1});
  f("patch_reefs", p.patch_reefs, Range{0, 1});
  f("passes", p.passes, Count{0, 64});
  f("random_passes", p.random_passes, Range{0, 16});
  f("motu", p.motu, Count{0, 256});
  f("random_motu", p.random_motu, Range{0, 64});
  f("groove_spacing_m", p.groove_spacing_m, Range{5, 200});
  f("groove_amplitude_m", p.groove_amplitude_m, Range{0, 10});
  f("groove_depth_m", p.groove_depth_m, Range{2, 60});
  f("flat_width_m", p.flat_width_m, Range{0, 5000});
  f("windward_flat_gain", p.windward_flat_gain, Range{0, 0.9});
  f("crest_width_m", p.crest_width_m, Range{5, 300});
  f("fore_reef_m", p.fore_reef_m, Range{20, 1000});
  f("fore_reef_depth_m", p.fore_reef_depth_m, Range{2, 60});
  f("abyss_decay_m", p.abyss_decay_m, Range{10, 1e5});
  f("abyss_relief_m", p.abyss_relief_m, Range{0, 30});
}

// The paper's generator alone (Eqs. 1–9, docs/DESIGN.md §3): its coral
// anchors (lagoon −20 m, crest −2 m on [0.75, 0.8], abyss −100 m) and no reef
// geomorphology. The tests of the paper's equations start from this.
inline void use_paper_reef(struct IslandSpec& s);

// Multiplicative surface noise on the volcano heights (signed metres, so the
// 0 m coastline of the profile is kept exactly where the outlines put it).
struct DetailNoise {
  double amplitude = 0.1;   // fraction of |h|, [0, 0.5]; 0 switches it off
  double feature = 0.04;    // canvas units per noise feature (0.04 = W/50 px), [0.005, 1]
  int octaves = 3;          // fBm octaves, [1, 4]
  uint64_t seed = 0;        // noise seed (random islands derive it from the global seed)
  double shield = 1.0;          // relative relief of the shield's rift ridges and lava lobes before erosion (docs/EROSION.md "The shield"), [0, 2]; 0 off
  double shield_feature = 0.35; // canvas units per lava lobe of the shield, [0.02, 2]
};
template <class F>
void fields(DetailNoise& p, F&& f) {
  f("amplitude", p.amplitude, Range{0, 0.5});
  f("feature", p.feature, Range{0.005, 1});
  f("octaves", p.octaves, Range{1, 4});
  f("seed", p.seed);
  f("shield", p.shield, Range{0, 2});
  f("shield_feature", p.shield_feature, Range{0.02, 2});
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
  double age_myr = -1;                             // My since the shield was built, [0, 60]; sets subsidence and maturity (procgen/age.hpp); -1 = not set
  double maturity = -1;                            // erosion maturity, multiple of erosion.duration_yr, [0.05, 20]; -1 = from age_myr (none without it)
  HeightMapping heights;
  CoralParams coral;
  ReefParams reef;                                 // reef geomorphology after coral growth (docs/REEF.md)
  double smax_k = 0.5;                             // 1/m, smooth-max sharpness (overshoot ≤ 1/(2k) m), [0.01, 100]
  DetailNoise noise;
  terrain::ErosionParams erosion;                           // fluvial erosion of the land before coral growth (docs/EROSION.md)
  terrain::RainParams rain;                        // rain from the wind strokes' mean direction, read by the erosion as discharge (docs/EROSION.md)
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
  f("age_myr", s.age_myr, Range{-1, 60});
  f("maturity", s.maturity, Range{-1, 20});
  f("heights", s.heights);
  f("coral", s.coral);
  f("reef", s.reef);
  f("smax_k", s.smax_k, Range{0.01, 100});
  f("noise", s.noise);
  f("erosion", s.erosion);
  f("rain", s.rain);
  f("world_size_m", s.world_size_m, Range{10, 1e6});
}

inline void use_paper_reef(IslandSpec& s) {
  s.reef.enabled = false;
  s.coral.back_m = -20, s.coral.crest_m = -2, s.coral.abyss_m = -100;
  s.coral.back_end = 0.5, s.coral.flat_begin = 0.5, s.coral.flat_m = -20;
}

// Throws reefgen::Error naming the first invalid field and its valid range.
void validate(const IslandSpec& spec);

// JSON (the field walk): every field optional (defaults above); unknown keys
// are rejected so a typo does not silently fall back to a default.
void to_json(nlohmann::json& j, const IslandSpec& s);
void from_json(const nlohmann::json& j, IslandSpec& s);
// Parses and validates; errors name `origin` (a file name) and the field.
// age_myr and maturity come back applied and cleared (procgen/age.hpp aged()).
IslandSpec spec_from_json(const nlohmann::json& j, const std::string& origin);

}  // namespace reefgen::procgen
