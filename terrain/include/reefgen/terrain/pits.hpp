#pragma once
// The closed depressions left in a height field after erosion or in a model
// answer: filled, then breached (docs/EROSION.md). Deterministic and
// single-threaded.
#include <cstdint>

#include <opencv2/core.hpp>

namespace reefgen::terrain {

// Closed depressions shallower than this are left as they are (m): half the
// 1 m a pit must have to count in the realism statistics (docs/REALISM.md).
constexpr float kPitDepthM = 0.5f;

// A drained depression shaped like a valley (drain_pits with a cell size)
// keeps this fall along its raised floor and its breach, 1 %: a channel cut
// into an island's flank falls more than that, and a flat fill (0 %) or a
// flat breach reads from above as a canal (docs/EROSION.md "Pits").
constexpr double kDrainFloorSlope = 0.01;
// A breach's banks rise at most this much per metre from the cut (0.6, 31°:
// a valley side), over at most kBreachBankMaxPx cells.
constexpr double kBreachBankSlope = 0.6;
constexpr int kBreachBankMaxPx = 4;
// Fall left to a breach (m) when a depression lies near sea level: its floor
// is raised so that the cut can fall this much before it reaches the land's
// floor (kLandFloorM), where it would run on flat.
constexpr double kBreachRoomM = 0.5;

// Drains the closed depressions of the land that are deeper than
// `max_depth_m` (the remaining pits of an eroded or predicted field): one
// deeper than `breach_m` is first raised to breach_m below its spill level,
// then its outflow path is cut down (breached) so that water leaves it; with
// breach_m ≤ max_depth_m they are only filled, to max_depth_m below the spill
// (flat floors). Returns the cells changed.
// With cell_m > 0 (metres per pixel) the drained depression is shaped like a
// valley instead: its raised floor falls towards the spill point at
// kDrainFloorSlope (lowest there, at most the flat floor's height unless the
// depression lies so near sea level that the cut needs kBreachRoomM), every
// breach cut falls at kDrainFloorSlope too, and its banks are opened to
// kBreachBankSlope — no flat floor, no flat slot.
int64_t drain_pits(cv::Mat1f& height_m, float max_depth_m = kPitDepthM, float breach_m = 0.f, double cell_m = 0);

}  // namespace reefgen::terrain
