#pragma once
// Flow routing: where the water of every cell of a height field goes.
// Priority-Flood (closed depressions routed to their spill point) and the
// flow graph the eroders and the drainage accumulation walk (receivers and
// the stack, Braun & Willett 2013), built once per routing as in
// fastscapelib. LibTorch-free; every function is deterministic and
// single-threaded (docs/EROSION.md).
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace reefgen::terrain {

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
// the cells that can enter it (its keys are monotone; priority_flood.cpp says why).
FloodRoute flood_route(const cv::Mat1f& height, const cv::Mat1b& role);

// Roles for "water leaves at the sea (h ≤ sea_m) and at the canvas edge":
// land cells active, the sea and every edge cell outlets.
cv::Mat1b sea_and_edge_roles(const cv::Mat1f& height_m, float sea_m = 0.f);

// The box around the cells above sea level (h > 0), grown by one cell (their
// outlets, or the canvas edge); empty when there is no land. Islands cover a
// minority of the canvas: routing works on this box.
cv::Rect land_box(const cv::Mat1f& height_m);

// A drainage graph, built once per routing: each active cell's receiver
// (the neighbour it drains to; itself for outlets and base levels), the
// inverse distance to it, and the stack (active cells, every receiver before
// its donors): a forward sweep solves the implicit stream-power law, a
// reverse sweep accumulates drainage area. `surface` is what the routing saw
// (the Priority-Flood filled surface, or the heights themselves, sharing
// their data); the multiple-flow-direction accumulation reads its slopes.
struct FlowGraph {
  std::vector<int> receiver;
  std::vector<float> inv_length;  // 1 / distance to the receiver, 1/m (stack cells only)
  std::vector<int> stack;
  cv::Mat1f surface;
};

// Steepest descent on the Priority-Flood filled surface (Barnes et al.
// 2014); in a filled depression, where no neighbour is lower, the flood's
// own path to the spill point. Stack = the flood's order. height_m and role
// continuous, of the same size; active cells not on the canvas edge.
void route_flood(const cv::Mat1f& height_m, const cv::Mat1b& role, double metres_per_px, FlowGraph& graph);

// Braun & Willett (2013), O(n): receivers on height_m itself, then the donor
// tree walked breadth-first from every base level (an outlet, or a local
// minimum that is its own receiver). salt = 0: the steepest lower neighbour
// (D8). salt ≠ 0: a lower neighbour drawn with probability ∝ slope² from a
// hash of (cell, salt), the same whatever the threads: on a smooth slope D8
// draws straight gullies along the 8 grid directions, random receivers let
// them wander. For surfaces already drained (the refinement levels).
// `graph` is reused: its buffers keep their capacity between calls.
void route_stack(const cv::Mat1f& height_m, const cv::Mat1b& role, double metres_per_px, uint64_t salt,
                 FlowGraph& graph);

}  // namespace reefgen::terrain
