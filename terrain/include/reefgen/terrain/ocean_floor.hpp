#pragma once
// The submarine flank below the training range (docs/REEF.md "Deeper than
// the abyss"): generator and model keep the paper's −100 m floor; a user who
// wants the real ocean (−1000 … −4000 m within a few km of a reef island)
// asks for it with --ocean-floor-m and the flank is continued down to it by
// the distance from the reef, at a real flank's slopes.
#include <opencv2/core.hpp>

#include "reefgen/constants.hpp"

namespace reefgen::terrain {

// Below this height (m) the open-ocean side of the field is the submarine
// flank: deeper than any lagoon floor of the training targets (≤ 60 m but for
// the largest atolls) and than the fore reef's spur-and-groove.
inline constexpr float kFlankKneeM = -60.f;
// The deepest and the shallowest floor one may ask for, m: the Mariana
// Trench, and the knee (above it there is no flank to continue).
inline constexpr double kDeepestOceanFloorM = -11000, kShallowestOceanFloorM = kFlankKneeM;
// The slope (m per m) with which the continued flank leaves the knee: tan 35°,
// the outer slopes of atolls and barrier reefs below −20 m (25° at Bikini
// from 0 to 366 m, 30–45° elsewhere; docs/REEF.md). Deeper it relaxes.
inline constexpr double kFlankTopSlope = 0.70;

// The Gaussian σ (cells) that smooths the distance from the reef near it
// (terrain/src/ocean_floor.cpp: the exact distance's creases draw lines);
// 8 cells, the least that left no line beside the reef in a hill-shade of
// the atoll preset at 1025² (3 still drew them).
inline constexpr double kFlankDistanceBlurPx = 8;
// Far from the reef the σ is this share of the canvas side, and at least
// this many near σ: the creases of a wavy reef's distance run straight out
// to the canvas edge, a fan that σ = 8 cells only softened.
inline constexpr double kFlankFarBlurShare = 1.0 / 32;
inline constexpr int kFlankFarBlurMinRatio = 4;
// How far the blended distance can rise per cell of distance: 1 for each
// blur, plus the blend's slope (1.5 per its span, 3 (far − near) σ) times
// their largest difference (σ √(π/2) each): 1 + 1.5 · 1.2533 · 5/9 = 2.05 at
// the least ratio of 4, less at larger ones.
inline constexpr double kFlankDistanceSteepest = 2.05;

// The depth (m, ≥ 0) added to an open-ocean cell at distance_m from the reef
// when the flank continues span_m further down: span_m·tanh(distance·s/span),
// s = kFlankTopSlope — the flank leaves the reef at s and relaxes as it nears
// the floor (¾ s halfway down, a fifth of s at 90 %), as the submarine slopes
// of reef islands flatten towards the abyssal plain.
double flank_drop_m(double distance_m, double span_m);

// Continues the ocean's flank towards ocean_floor_m: cells below kFlankKneeM
// that reach the field's border through cells below it (the open ocean, not a
// lagoon behind its rim) sink by flank_drop_m of their distance from the
// nearest other cell (the reef, the land, a lagoon; smoothed as
// terrain/src/ocean_floor.cpp says), never below
// ocean_floor_m. The span is the floor asked less the ocean's lowest cell, so
// the field's own relief below the knee is kept and the floor is approached
// where the distance allows: a 6 km canvas's atoll reaches about −700 m at
// its edges for −2000 (a real flank is kilometres wide). Continuous at the
// knee; no step steeper than the field's own plus kFlankTopSlope ×
// kFlankDistanceSteepest (1.4 m per m). Where
// region (region ids, any size: resized nearest) marks a lagoon, the cells
// are kept whatever their depth and the ocean does not pass through them
// (a painted lagoon reaching the sea below the knee). cell_m is the cells'
// size in metres. Nothing changes when the ocean is already as deep. Throws
// reefgen::Error for a non-finite depth, one outside [kDeepestOceanFloorM,
// kShallowestOceanFloorM], or a cell size that is not positive.
void deepen_flank(cv::Mat1f& height_m, double ocean_floor_m, double cell_m, const cv::Mat1b& region = {});

}  // namespace reefgen::terrain
