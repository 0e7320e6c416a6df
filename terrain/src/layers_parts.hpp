#pragma once
// Pieces of the layer computation that the whole-field layers (layers.cpp)
// and a world's tiled layers (world_layers.cpp) share. terrain/src only.
#include <algorithm>
#include <functional>

#include <opencv2/core.hpp>

#include "reefgen/terrain/flow.hpp"

namespace reefgen::terrain::detail {

// row(y) for every y < rows, in bands of rows shared out over `threads`
// (each pixel written by one thread only: same bytes whatever the count).
void for_rows(int rows, int threads, const std::function<void(int)>& row);
// The share of region `id` around each pixel: its indicator blurred with a
// Gaussian-like kernel of σ sigma_px (three box passes past σ = 3).
cv::Mat1f region_share(const cv::Mat1b& region, int id, double sigma_px);
// Slope (degrees) and unit normals by central differences (one-sided on the
// canvas edge); row 0 is north.
void slope_and_normals(const cv::Mat1f& h, double dx, cv::Mat1f& slope_deg, cv::Mat3f& normal, int threads);
// Drainage area (Priority-Flood, Quinn's shared flow) on the land's box; 0 elsewhere.
cv::Mat1f drainage_area(const cv::Mat1f& h, double dx, FlowGraph& graph, cv::Rect& box);
// Adds to deposit_m where the worn material settles along graph's receivers.
void settle_sediment(const FlowGraph& g, const cv::Rect& box, const cv::Mat1f& h_full, const cv::Mat1f& wear_full,
                     const cv::Mat1f& slope_full, double dx, double settle_deg, cv::Mat1f& deposit_full);
// Whether ground the finishing raised at (y, x) of h is fill, laid down:
// gentler than settle_deg and not convex (its four neighbours' mean at
// least its height; the canvas edge replicated). The amplification raises
// summits and their flanks too (tens of metres above the answer it
// started from): that is relief, not sediment, and a deposit mask of it
// was 80 m next to the summits.
inline bool raised_is_fill(const cv::Mat1f& h, int y, int x, float slope_deg, double settle_deg) {
  if (!(slope_deg < settle_deg)) return false;
  auto at = [&](int yy, int xx) { return h(std::clamp(yy, 0, h.rows - 1), std::clamp(xx, 0, h.cols - 1)); };
  return at(y - 1, x) + at(y + 1, x) + at(y, x - 1) + at(y, x + 1) >= 4.f * h(y, x);
}
// Throws reefgen::Error when the inputs cannot make layers.
void check_inputs(const cv::Mat1f& h, const cv::Mat1f& before, const cv::Mat1b& region, double dx);

}  // namespace reefgen::terrain::detail
