#pragma once
// One age for an island (docs/SPEC.md "Age"): the mappings from an age in
// millions of years to the subsidence λ and to the erosion maturity, shared
// by the generator (procgen/age.hpp), inference and worlds. LibTorch-free.
#include <algorithm>
#include <cmath>

namespace reefgen {

// A spec field that is not set.
inline constexpr double kNotSet = -1;
inline constexpr double kMaxAgeMyr = 60;
inline constexpr double kMinMaturity = 0.05, kMaxMaturity = 20;

// Subsidence follows the square root of age, as the sea floor under a
// hotspot island cools and sinks (depth ∝ √t: Parsons & Sclater 1977;
// Detrick & Crough 1978 for hotspot swells): λ(t) = min(1, √(t / T)), T the
// age at which the island is an atoll. T = 60 My puts the Society Islands
// about where reefgen's subsidence draws them (approximate K–Ar ages of
// their shields): Moorea (~1.5–2 My) λ ≈ 0.17, a fringing reef turning
// barrier; Bora Bora (~3.5 My) 0.24 and Maupiti (~4.5 My) 0.27, barrier
// reefs round high islands (the barrier-reef preset is 0.3); the Tuamotu
// atolls, on edifices 40–60 My old, 0.8–1. Hotspots differ in pace (the
// Hawaiian islands carry fringing reefs at 5 My): set `subsidence` to place
// an island off this curve.
inline constexpr double kAtollAgeMyr = 60;
inline double subsidence_of_age(double age_myr) {
  return std::min(1.0, std::sqrt(std::max(0.0, age_myr) / kAtollAgeMyr));
}

// Erosion maturity grows with time: the time eroded is the age, as a
// multiple of the generator's default erosion (erosion.duration_yr =
// 1.5e5 yr of the default K, a moderately dissected island) at
// kUnitMaturityAgeMyr. A young shield (0.25 My, as the shields of the
// island of Hawaiʻi) has maturity 0.25: shallow radial gullies,
// much of its land high; Kauaʻi (5 My) 5: valleys cut to the sea between
// ridges that stand. O'Hara et al. (Earth Surface Dynamics 12:709, 2024)
// find drainage density rising and basin hypsometry falling with edifice
// age over this range; `reefgen realism --dissection` measures both
// (docs/REALISM.md "Age and dissection").
inline constexpr double kUnitMaturityAgeMyr = 1;
inline double maturity_of_age(double age_myr) {
  return std::clamp(age_myr / kUnitMaturityAgeMyr, kMinMaturity, kMaxMaturity);
}

// The maturity an island is eroded at: `maturity` when set, else its age's,
// else kNotSet (the erosion as given).
inline double maturity_for(double age_myr, double maturity) {
  if (maturity != kNotSet) return maturity;
  return age_myr != kNotSet ? maturity_of_age(age_myr) : kNotSet;
}

}  // namespace reefgen
