#pragma once
// Seeds that re-roll the island (docs/INFERENCE.md "Variations"): the
// network answers a painting with one island, the mean of those it saw for
// that painting. A seed moves the summit and ridges inside the painted land
// before the amplification, whose seeded lobes, roughening and erosion then
// cut the valleys anew. LibTorch-free.
#include <cstdint>

#include <opencv2/core.hpp>

#include "reefgen/infer/amplify_params.hpp"

namespace reefgen::infer {

// How far a cell's height may come from, as a share of the cell's distance
// to the coast (the warp never reaches the sea: |shift| < distance, so the
// coast, the sea and every painted region stay where they are, and the
// warp never folds: its gradient stays below 1). 0.45 moves a 3 km-wide
// island's summit by up to ~700 m.
inline constexpr double kRerollShiftShare = 0.7;
// Size of the warp's features, m: an island's summit and main ridges
// (two octaves, 4 and 2 km: a lean of the whole massif, bent across it).
inline constexpr double kRerollFeatureM = 4000;
// The lean (a share of the unit disc, in a direction of the seed's own:
// seed n at n golden angles) and the bend (the noise's weight) of the shift.
inline constexpr double kRerollLean = 0.7;
inline constexpr double kRerollBend = 0.8;
inline constexpr double kGoldenRatioConjugate = 0.6180339887498949;

// The distance to the coast has creases along each island's medial axis
// (its gradient turns there); a warp ∝ that distance folds the answer's
// flanks into a V along each crease and, where creases meet, into a closed
// basin (12 m deep, 1.4 × 3.5 km on a 20 km island) that the erosion
// deepens and the pit draining then cuts a straight gorge out of. Each
// island's D is replaced by a soft minimum of D and G_σ ∗ D, σ = this share
// of the island's widest D: still ≤ D and 1-Lipschitz (no fold, the coast
// unmoved), smooth across the creases.
inline constexpr double kRerollCreaseShare = 0.3;
// dist_px: the distance to the nearest sea cell (0 at sea), px.
cv::Mat1f creaseless_distance(const cv::Mat1f& dist_px);

// h'(x) = h(x + v·k·D(x)·n(x)) on land (h > 0), k = kRerollShiftShare, v =
// variation in [0, 1], D the distance to the nearest sea cell (px), n the
// seed's lean plus a seeded noise, held to |n| ≤ 1. The sea is unchanged; land stays land.
// Pure in (height_m, cell size, seed, variation); any shape.
cv::Mat1f reroll_land(const cv::Mat1f& height_m, double metres_per_px, uint64_t seed, double variation);

// What infer and world amplify: the answer re-rolled (reroll_land) and the
// amplification's params for it — a re-rolled island is eroded at the
// model's side too, so its valleys are its own. variation 0: both unchanged.
struct Rerolled {
  cv::Mat1f height_m;
  AmplifyParams params;
};
Rerolled reroll_for_amplify(const cv::Mat1f& height_m, double metres_per_px, uint64_t seed, double variation,
                            const AmplifyParams& params);

}  // namespace reefgen::infer
