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
// The flank stretched spans at least this much below the knee (m): a field
// whose open ocean reached only a hair below it (one cell at −60.00001 m)
// had that cell stretched alone to the floor asked, an 11 km needle. Every
// output's ocean reaches well past it (the paper's floor is −100 m; a 64²
// canvas's deepest cell −91 m).
inline constexpr float kMinFlankSpanM = 10.f;
// The deepest and the shallowest floor one may ask for, m: the Mariana
// Trench, and the knee (above it the flank is not stretched at all).
inline constexpr double kDeepestOceanFloorM = -11000, kShallowestOceanFloorM = kFlankKneeM;

// Stretches the ocean's flank down to ocean_floor_m: cells below
// kFlankKneeM that reach the field's border through cells below it (the open
// ocean, not a lagoon behind its rim) map linearly from [their lowest value,
// kFlankKneeM] to [ocean_floor_m, kFlankKneeM]: continuous at the knee, the
// ocean's lowest cell at ocean_floor_m (the range mapped reaches at least
// kMinFlankSpanM below the knee). Nothing changes when that cell is already
// as deep. Throws reefgen::Error for a non-finite depth or one outside
// [kDeepestOceanFloorM, kShallowestOceanFloorM].
void deepen_flank(cv::Mat1f& height_m, double ocean_floor_m);

}  // namespace reefgen::terrain
