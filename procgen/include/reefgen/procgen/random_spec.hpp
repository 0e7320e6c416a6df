#pragma once
// Random island configurations following the paper's data generation (§5,
// docs/DESIGN.md §4). Deterministic in (seed, index).
#include <cstdint>
#include <vector>

#include "reefgen/procgen/spec.hpp"

namespace reefgen::procgen {

struct RandomSpecParams {
  double radius_scale_min = 0.8;   // f ~ U[min, max] per outline, [0.1, 2]
  double radius_scale_max = 1.1;
  double outline_noise = 0.2;      // relative fBm amplitude of each outline in θ, [0, 0.5]
  double center_shift = 0.2;       // canvas units, max shift of the island and beach outlines, [0, 0.5]
  double curve_noise_max = 0.2;    // a ~ U[0, max] on profile and resistance, [0, 0.5]
  int strokes_min = 2, strokes_max = 5;         // wind strokes per island, [0, 64]
  int stroke_points_min = 20, stroke_points_max = 40;  // random-walk points, [2, 1024]
  double strength_min = 0.05, strength_max = 0.8;      // canvas units
  double width_min = 0.1, width_max = 0.8;             // canvas units
  int control_radii = 30;          // K per outline, [4, 256]
};

// A random configuration (subsidence 0; render it at several levels).
IslandSpec random_spec(uint64_t seed, uint64_t index, const RandomSpecParams& p = {});

// `count` subsidence levels evenly spaced on [0, 1] (count 1 → {0}).
std::vector<double> subsidence_levels(int count);

}  // namespace reefgen::procgen
