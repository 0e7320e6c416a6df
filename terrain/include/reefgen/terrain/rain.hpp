#pragma once
// Rain from the wind (docs/EROSION.md "Rain from the wind"): the linear
// theory of orographic precipitation (Smith & Barstad 2004, J. Atmos. Sci.
// 61:1377, their Eq. 49) on the island's heights. Moist air forced up the
// windward flank condenses; the condensate needs τ_c to form and τ_f to
// fall, so the rain is carried downwind of the slope that lifted it and the
// lee, where the air descends, is left dry — Kohala's > 4000 mm/yr windward
// and < 250 mm leeward. The erosion reads it as discharge: Q = Σ P·a over
// the upstream cells instead of the area alone (stream power K Q^m S).
// LibTorch-free, deterministic (OpenCV's DFT in float, the transfer in double).
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reefgen/params_json.hpp"

namespace reefgen::terrain {

struct RainParams {
  bool enabled = true;                // false: the same rain everywhere (discharge = area)
  double background_mm_yr = 1500;     // rain over the open sea upwind, mm/yr, [1, 20000]
  double wind_speed_m_s = 10;         // the prevailing (trade) wind, m/s, [0.5, 50]
  double condensation_s = 400;        // τ_c, time for lifted vapour to condense, s (trade-wind warm rain; 1000–2000 over large ranges), [1, 1e5]
  double fallout_s = 400;             // τ_f, time for the condensate to fall out, s, [1, 1e5]
  double uplift_sensitivity = 5e-4;   // C_w, kg/m³: Smith & Barstad's 0.004–0.005 for a storm, times a tenth for the share of the year it rains (a year's mean), [0, 0.1]
  double moist_stability_hz = 0.005;  // N_m, moist Brunt–Väisälä frequency, 1/s, [0, 0.1]
  double vapour_height_m = 2500;      // H_w, depth of the moist layer, m, [100, 10000]
  double floor_share = 0.05;          // the driest cell's rain as a share of the background, [0, 1]
  double evapotranspiration_mm_yr = 0;  // rain that evaporates or transpires before it runs off (runoff = P − ET, at least kMinRunoffShare·P), mm/yr, [0, 10000]
};

template <class F>
void fields(RainParams& p, F&& f) {
  f("enabled", p.enabled);
  f("background_mm_yr", p.background_mm_yr, Range{1, 20000});
  f("wind_speed_m_s", p.wind_speed_m_s, Range{0.5, 50});
  f("condensation_s", p.condensation_s, Range{1, 1e5});
  f("fallout_s", p.fallout_s, Range{1, 1e5});
  f("uplift_sensitivity", p.uplift_sensitivity, Range{0, 0.1});
  f("moist_stability_hz", p.moist_stability_hz, Range{0, 0.1});
  f("vapour_height_m", p.vapour_height_m, Range{100, 10000});
  f("floor_share", p.floor_share, Range{0, 1});
  f("evapotranspiration_mm_yr", p.evapotranspiration_mm_yr, Range{0, 10000});
}
void to_json(nlohmann::json& j, const RainParams& p);
RainParams rain_params_from_json(const nlohmann::json& j, const std::string& origin);

// Rain in mm/yr on every cell of height_m (metres; the sea, h ≤ 0, lifts no
// air) for a wind blowing towards `wind_to` (image axes: x right, y down;
// any length > 0, normalised here). The field is zero-padded to twice its
// size before the DFT, so an island's rain does not wrap round the canvas.
// Throws reefgen::Error on an empty field, a non-positive cell size or a
// zero wind vector.
cv::Mat1f orographic_rain_mm_yr(const cv::Mat1f& height_m, double metres_per_px, cv::Vec2d wind_to,
                                const RainParams& p);

// The share of the rain that runs off where evapotranspiration takes more
// than falls: a dry lee's streams still carry its storms' floods.
inline constexpr double kMinRunoffShare = 0.1;
// Runoff R = max(P − ET, kMinRunoffShare·P) over its mean on the land
// (h > 0): what multiplies each cell's area in the discharge (Q = Σ R·a).
// ET turns a modest rain contrast into a runoff contrast, as on Kauaʻi's
// lee, where 500 mm/yr of rain leaves almost nothing to run off. All ones
// where there is no land.
cv::Mat1f runoff_relative_to_land_mean(const cv::Mat1f& rain_mm_yr, const cv::Mat1f& height_m,
                                       double evapotranspiration_mm_yr);

// The rain's grid: the orographic field is smooth over U·τ (4 km at the
// defaults), so 128 cells across a canvas (47 m at the default 6 km) hold
// it; upsampled after.
inline constexpr int kRainGridPx = 128;

// The rain an erosion reads, at the heights' size: in mm/yr, and each cell's
// runoff over the land's mean (the discharge's weight, erode_level's rain_rel).
struct RainFields {
  cv::Mat1f mm_yr, runoff_rel;
};
// orographic_rain_mm_yr on height_m (square, world_size_m wide) averaged to
// min(kRainGridPx, side) cells, then runoff_relative_to_land_mean, both
// upsampled bilinearly. Used by the generator and by `reefgen erode --wind-from`.
RainFields rain_for_erosion(const cv::Mat1f& height_m, double world_size_m, cv::Vec2d wind_to, const RainParams& p);

}  // namespace reefgen::terrain
