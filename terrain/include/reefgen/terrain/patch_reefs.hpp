#pragma once
// Patch reefs and pinnacles on a lagoon floor (docs/REEF.md "The steps"):
// one rule for the generator's lagoons (procgen reef.cpp) and for the
// painted lagoons a model answer is finished with (infer reef_finish.cpp).
#include <algorithm>

#include "reefgen/ramp.hpp"
#include "reefgen/terrain/noise.hpp"

namespace reefgen::terrain {

// Feature size of the patch-reef noise (m): about the spacing of patch
// reefs on atoll lagoon floors, a few per km².
inline constexpr double kPatchCellM = 250;
// A knoll's side spans kKnollSideFbm of the fbm per kKnollReliefRefM of
// relief (m) above the floor, and at least that.
inline constexpr double kKnollSideFbm = 0.12;
inline constexpr double kKnollReliefRefM = 12;

// patch_reef_m's knoll from the noise coordinates (u, v) = (xm, ym) / kPatchCellM
// and the 3-octave fbm already read there (n = noise.fbm(u, v, 3)): for
// loops that read the fbm of a whole row at once (GradientNoise2::fbm_n).
inline float patch_reef_from_fbm_m(const GradientNoise2& noise, float u, float v, double n, double depth_m,
                                   double density) {
  // fbm is roughly symmetric about 0 with |n| < 0.6: density 0 → no knolls,
  // 1 → about a third of the floor.
  const double threshold = 0.35 - 0.4 * density;
  if (n <= threshold) return -1e30f;
  const double top = -0.5 - 5.5 * (0.5 + 0.5 * noise.perlin(u * 0.37f + 11.f, v * 0.37f - 5.f));
  // The side spans more of the noise the taller the knoll, so its slope does
  // not grow with the lagoon's depth (0.12 of the noise for any relief stood
  // at up to 78° in a 26 m lagoon at 2049²).
  const double side = kKnollSideFbm * std::max(1.0, (depth_m + top) / kKnollReliefRefM);
  const double t = std::clamp((n - threshold) / side, 0.0, 1.0);
  const double rise = smoothstep(t);
  return float(-depth_m + (depth_m + top) * rise);
}

// Where a band-limited noise field (features of ~kPatchCellM) rises above a
// threshold set by `density` ([0, 1]: none to about a third of the floor),
// the floor at depth_m (positive) rises to a knoll whose top lies 0.5–6 m
// under water (One Tree Reef's lagoon: patch reefs to near the surface), in
// irregular clusters as on real lagoon floors. Returns the knoll surface at
// (xm, ym) metres, or −1e30 where there is none; callers take the max with
// their floor.
inline float patch_reef_m(const GradientNoise2& noise, double xm, double ym, double depth_m, double density) {
  const float u = float(xm / kPatchCellM), v = float(ym / kPatchCellM);
  return patch_reef_from_fbm_m(noise, u, v, noise.fbm(u, v, 3), depth_m, density);
}

}  // namespace reefgen::terrain
