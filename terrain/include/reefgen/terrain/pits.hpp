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
// flat breach reads from above as a canal (docs/EROSION.md "The equations":
// "Shaped like a valley, not a lake and a slot").
constexpr double kDrainFloorSlope = 0.01;
// A breach's banks rise at most this much per metre from the cut (0.6, 31°:
// a valley side), over at most kBreachBankMaxPx cells.
constexpr double kBreachBankSlope = 0.6;
constexpr int kBreachBankMaxPx = 4;
// Fall left to a breach (m) when a depression lies near sea level: its floor
// is raised so that the cut can fall this much before it reaches the land's
// floor (kLandFloorM), where it would run on flat.
constexpr double kBreachRoomM = 0.5;

// The least fall a land cell keeps along its route to the sea after
// grade_land (m per m), 0.7 %: above the 0.5 % below which the realism
// report calls ground flat (docs/REALISM.md "Straight flat channels"), with
// room for the central difference's loss where two routes part.
constexpr double kLandMinSlope = 0.007;

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

// Every land cell falls at least `slope` (m per m) along its route to the
// sea: z_i ≥ z_r + s·|i − r| for its lowest neighbour r already graded, s
// varying over the ground from `slope` to 1.85 times it, and z_i ≥
// kLandFloorM next to the sea. Priority-Flood+ε (Barnes, Lehman & Mulla 2014,
// Computers & Geosciences 62) with ε the fall of one step at `slope`: a flat
// (a lowland held at the land's floor, a filled floor, a shallow pit's fill)
// gets a gradient towards its outlet; ground that already falls that much
// is untouched, and nothing is lowered. Returns the cells raised.
// Whole fields only: on a band of a larger field the band's edges would be
// outlets, and two bands would grade one flat towards different edges.
int64_t grade_land(cv::Mat1f& height_m, double cell_m, double slope = kLandMinSlope);

}  // namespace reefgen::terrain
