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
// ocean, not a lagoon behind its rim) map linearly from [their lowest value,
// kFlankKneeM] to [ocean_floor_m, kFlankKneeM]: continuous at the knee, the
// ocean's lowest cell at ocean_floor_m. Nothing changes when that cell is
// already as deep. Throws reefgen::Error for a non-finite depth or one
// outside [-11000, -1] m.
void deepen_flank(cv::Mat1f& height_m, double ocean_floor_m);

}  // namespace reefgen::terrain
