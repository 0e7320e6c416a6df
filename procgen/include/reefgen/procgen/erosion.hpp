#pragma once
// Cheap erosion of a generated island (DESIGN §4: the authors' dataset code
// erodes every height field — thermal, hydraulic, thermal — with the
// resistance map modulating it). Ours is the same sequence, sized to a few
// milliseconds at 256²: the point is that the heights a model learns from
// carry gullies, talus and smoothed ridges instead of perfectly smooth
// profile sweeps, not a geomorphology simulation. No LibTorch here.
#include <cstdint>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace reefgen::procgen {

struct ErosionParams {
  int thermal_iterations = 20;     // first thermal pass, [0, 1000]
  double talus_slope = 0.45;       // m/m: steeper slopes shed material (≈ 24°), (0, 10]
  double thermal_rate = 0.25;      // share of the excess moved per iteration, [0, 0.5]
  int hydraulic_iterations = 30;   // [0, 1000]
  double rain_m = 0.6;             // water added per iteration on land (h > 0), [0, 100]
  double capacity = 0.35;          // sediment carried per metre of water and unit slope, [0, 100]
  double solubility = 0.3;         // share of the missing capacity eroded per iteration, [0, 1]
  double deposition = 0.3;         // share of the excess sediment dropped per iteration, [0, 1]
  double evaporation = 0.1;        // share of the water lost per iteration, [0, 1]
  int final_thermal_iterations = 10;  // second, gentler thermal pass, [0, 1000]
  double final_talus_slope = 0.6;     // m/m, (0, 10]
  double final_thermal_rate = 0.15;   // [0, 0.5]
  double noise_amplitude = 0.25;   // relative low-frequency modulation of the resistance, [0, 1]
};

void to_json(nlohmann::json& j, const ErosionParams& p);
// Every key optional; unknown keys and out-of-range values throw reefgen::Error naming `origin`.
ErosionParams erosion_params_from_json(const nlohmann::json& j, const std::string& origin);

// Erodes height_m (metres, sea level 0) in place. resistance ∈ [0, 1] per
// pixel (1 = hard rock, nothing moves); metres_per_px converts height steps to
// slopes. Only land (h > 0) is rained on; water that reaches the sea drops its
// load there, so eroded material builds the shore instead of vanishing.
// Deterministic: one fixed sweep order, no threads, noise drawn from `seed`.
void erode(cv::Mat1f& height_m, const cv::Mat1f& resistance, double metres_per_px, uint64_t seed,
           const ErosionParams& p = {});

}  // namespace reefgen::procgen
