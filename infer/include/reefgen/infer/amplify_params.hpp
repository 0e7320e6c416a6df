#pragma once
// The settings of a model answer's amplification (amplify_heights,
// amplify_world; docs/EROSION.md "At the model's side"): the generator's
// erosion it runs, and the shaping before it that only a model answer needs
// (roughening, lobes, the plain's smoothing, ponds). They live here, not in
// terrain::ErosionParams, so a spec or a dataset config — which the
// generator reads — refuses them as unknown keys. LibTorch-free.
#include <string>

#include <nlohmann/json.hpp>

#include "reefgen/params_json.hpp"
#include "reefgen/terrain/erosion.hpp"

namespace reefgen::infer {

struct AmplifyParams {
  terrain::ErosionParams erosion;   // the erosion and refinement it runs (the generator's defaults)
  double roughness = 0.8;           // relief added to the land before eroding, share of the height, [0, 1]
  double feature_m = 140;           // spacing of that relief's features, m, [1, 1e5]
  double relief_reach_m = 500;      // that relief follows the land's relief within this reach (its height over the lowest land there), not its height, m, [0, 1e5] (0 = the height)
  double duration_scale = 0.5;      // base-grid erosion time as a multiple of erosion.duration_yr, [0, 100]
  int steps = 3;                    // implicit steps of that erosion (few: the lobes' valleys are not captured), [0, 1000]
  double lobe_m = 500;              // flank contours pushed up or down the slope by up to this, m, [0, 2000]
  double lobe_spacing_m = 400;      // spacing of those lobes along a contour, m, [1, 1e5]
  double plain_smooth_m = 150;      // Gaussian σ that takes the model's rings off the beach/lagoon plain's land, m, [0, 2000] (0 = off)
  double low_island_m = 120;        // islands whose own peak is below this get that smoothing on all their land (fully below half), m, [0, 1e4] (0 = off)
  double pond_max_m2 = 2.5e5;       // sea enclosed by land up to this area (any size where painted island/beach) is raised to land, m², [0, 1e9] (0 = off)
  // Not a setting: the re-roll (reroll_for_amplify, variation > 0) sets it,
  // so a moved massif is eroded at the model's own side too. Off, the
  // model's side gets the light clean-up only (ponds raised, pits breached).
  bool erode_at_model_side = false;
};

// The one field list (common/params_json.hpp). One flat JSON object: the
// erosion's keys as terrain::ErosionParams names them, and this struct's
// with an "amplify_" prefix (infer --erosion FILE, docs/EROSION.md).
template <class F>
void fields(AmplifyParams& p, F&& f) {
  fields(p.erosion, f);
  f("amplify_roughness", p.roughness, Range{0, 1});
  f("amplify_feature_m", p.feature_m, Range{1, 1e5});
  f("amplify_relief_reach_m", p.relief_reach_m, Range{0, 1e5});
  f("amplify_duration_scale", p.duration_scale, Range{0, 100});
  f("amplify_steps", p.steps, Range{0, 1000});
  f("amplify_lobe_m", p.lobe_m, Range{0, 2000});
  f("amplify_lobe_spacing_m", p.lobe_spacing_m, Range{1, 1e5});
  f("amplify_plain_smooth_m", p.plain_smooth_m, Range{0, 2000});
  f("amplify_low_island_m", p.low_island_m, Range{0, 1e4});
  f("amplify_pond_max_m2", p.pond_max_m2, Range{0, 1e9});
}

void to_json(nlohmann::json& j, const AmplifyParams& p);
// Every key optional; unknown keys and out-of-range values throw reefgen::Error naming `origin`.
AmplifyParams amplify_params_from_json(const nlohmann::json& j, const std::string& origin);

// The amplification of an island `maturity` times as eroded (reefgen/age.hpp):
// its erosion terrain::matured, more steps for the longer time, and a young
// island roughened and lobed less (roughness and lobe_m × maturity below 1:
// fewer gullies on a young shield, and its contours not yet pushed into the
// spurs and re-entrants of valleys — at full lobes a 0.1 My answer was a
// starfish of petals converging on the summit, docs/EROSION.md).
AmplifyParams matured(const AmplifyParams& p, double maturity);

}  // namespace reefgen::infer
