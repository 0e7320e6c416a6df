#pragma once
// Drainage area: how much of the land drains through each cell (m²), the A
// of the stream-power law and the flow layer. Reverse sweeps of a FlowGraph's
// stack, O(n) (Braun & Willett 2013, §2.3). Only stack cells are written;
// `area_m2` keeps its size between calls (resized and zeroed when the grid
// changes). Deterministic and single-threaded.
#include <vector>

#include <opencv2/core.hpp>

#include "reefgen/terrain/flow.hpp"

namespace reefgen::terrain {

// Single flow direction: each cell passes its own cell_area_m2 plus all its
// donors' area whole to its receiver (D8 or the stack router's draw).
//   A_i = a + Σ_{j : r(j) = i} A_j
// rain (optional, one per cell of the grid): each cell contributes
// cell_area_m2 × rain[i] instead (discharge in units of the mean rain's
// area, rain.hpp): Q_i = a·P_i + Σ_{j : r(j) = i} Q_j.
void accumulate_single(const FlowGraph& graph, const cv::Mat1b& role, float cell_area_m2, std::vector<float>& area_m2,
                       const float* rain = nullptr);

// Multiple flow directions (Quinn et al. 1991): each cell's area is shared
// over its lower neighbours on graph.surface in proportion to slope^exponent
// (exponent 1 is Quinn's; large tends to the single steepest direction); a
// cell with no lower neighbour (a filled depression) passes it all to its
// receiver, the flood's path to the spill point. A single steepest direction
// draws straight parallel gullies along the 8 grid directions on smooth
// slopes; shared flow does not.
//   A_i = a + Σ_j A_j · S_ji^p / Σ_k S_jk^p
void accumulate_multiple(const FlowGraph& graph, const cv::Mat1b& role, float cell_area_m2, double metres_per_px,
                         float exponent, std::vector<float>& area_m2, const float* rain = nullptr);

}  // namespace reefgen::terrain
