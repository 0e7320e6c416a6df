#pragma once
// The submarine flank below the training range (docs/REEF.md "Deeper than
// the abyss"): generator and model keep the paper's −100 m floor; a user who
// wants the real ocean (−1000 … −4000 m within a few km of a reef island)
// asks for it with --ocean-floor-m and the flank is stretched down to it.
#include <opencv2/core.hpp>

#include "reefgen/constants.hpp"

namespace reefgen::terrain {

// Below this height (m) the open-ocean side of the field is the submarine
// flank: deeper than any lagoon floor of the training targets (≤ 60 m but for
// the largest atolls) and than the fore reef's spur-and-groove.
inline constexpr float kFlankKneeM = -60.f;

// Stretches the ocean's flank down to ocean_floor_m: cells below
// kFlankKneeM that reach the field's border through cells below it (the open
// ocean, not a lagoon behind its rim) map linearly from [model_floor_m,
// kFlankKneeM] to [ocean_floor_m, kFlankKneeM]: continuous at the knee, the
// field's lowest values at ocean_floor_m. ocean_floor_m ≥ model_floor_m
// changes nothing. Throws reefgen::Error for a non-finite depth or one
// outside [-11000, -1] m.
void deepen_flank(cv::Mat1f& height_m, double ocean_floor_m, double model_floor_m = kAbyssFloorM);

}  // namespace reefgen::terrain
