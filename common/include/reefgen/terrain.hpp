#pragma once
// Height-field analysis shared by the erosion (procgen) and by the realism
// statistics users and tests measure with (`reefgen realism`, docs/REALISM.md).
// LibTorch-free. Every function is deterministic and single-threaded.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace reefgen {

// Cell roles for flood_route: cells marked kIgnore are never visited, kOutlet
// cells are where water leaves (the sea, the canvas edge), kActive cells are
// routed to an outlet.
enum FloodRole : uint8_t { kIgnore = 0, kActive = 1, kOutlet = 2 };

struct FloodRoute {
  // Active cells in the order the flood took them out of its queues, i.e. by
  // non-decreasing filled height: every cell's receiver, and every neighbour
  // strictly lower on the filled surface, comes before it. A reverse sweep
  // accumulates drainage area (single or multiple flow directions), a forward
  // sweep solves the implicit stream-power equation (docs/EROSION.md).
  std::vector<int> order;
  // receiver[i] = flat index of the cell i drains to (itself for outlets and
  // unreached cells). D8: the neighbour through which the flood reached i,
  // which is i's lowest neighbour on the filled surface; in a closed
  // depression it is the path to the spill point.
  std::vector<int> receiver;
  // Filled surface: max(h, spill level) on active cells (Priority-Flood).
  cv::Mat1f filled;
};

// Priority-Flood (Barnes et al. 2014) with its plain-queue optimisation:
// cells below the current spill level are depression cells and skip the
// priority queue. Ties are broken by flat index, so the route is a pure
// function of the inputs. O(n): the priority queue is a radix-sorted list of
// the cells that can enter it (its keys are monotone; terrain.cpp says why).
FloodRoute flood_route(const cv::Mat1f& height, const cv::Mat1b& role);

// Roles for "water leaves at the sea (h ≤ sea_m) and at the canvas edge":
// land cells active, the sea and every edge cell outlets.
cv::Mat1b sea_and_edge_roles(const cv::Mat1f& height_m, float sea_m = 0.f);

// The realism statistics of docs/REALISM.md (issue 20's definitions), for a
// height field in metres with sea level 0.
struct RealismStats {
  int64_t land_cells = 0;    // h > 0
  int64_t flank_cells = 0;   // land with 10–90 % of the highest land height
  double max_height_m = 0;
  double pits = 0;      // share of land cells in closed depressions deeper than 1 m
  double terraces = 0;  // share of flank cells with slope < 2°
  double valleys = 0;   // share of flank cells that are convergent (plan curvature < −1e-3 1/m on
                        // heights smoothed by a Gaussian of σ = 60 m, where the gradient > 0.02)
};

// metres_per_px: horizontal size of a cell. Throws reefgen::Error on an empty,
// non-finite field or a non-positive cell size.
RealismStats realism_stats(const cv::Mat1f& height_m, double metres_per_px);

// Plan curvature −(h_xx h_y² − 2 h_xy h_x h_y + h_yy h_x²) / (h_x² + h_y²)^{3/2}
// (1/m; negative = convergent, a valley) and gradient magnitude (m/m) by
// central differences, on heights already smoothed by the caller.
void plan_curvature(const cv::Mat1f& smooth_m, double metres_per_px, cv::Mat1f& curvature, cv::Mat1f& gradient);

}  // namespace reefgen
