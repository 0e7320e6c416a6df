#pragma once
// The reef report of `reefgen realism` (docs/REALISM.md "Reef"): what a reef
// island's reef looks like in numbers, from heights alone (sea level 0), to
// set beside real reefs. LibTorch-free, deterministic.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace reefgen::terrain {

// Rays cast from the island's centre for the crest and lagoon figures.
inline constexpr int kReefRays = 360;
// A ray's reef is the shallowest ground within kReefBandM inward of its last
// cell above kReefEdgeM (the fore reef's top), up to the first land: the crest.
inline constexpr double kReefEdgeM = -30;
inline constexpr double kReefBandM = 900;
// Crest at or above this counts as "at sea level" (the bars' −1 m).
inline constexpr double kCrestAtSeaM = -1;
// A run of rays whose crest is deeper than this is a pass.
inline constexpr double kPassCrestM = -3;
// Land components lower than this (m) are motu (sand islets), not high islands.
inline constexpr double kMotuMaxHeightM = 8;

struct ReefStats {
  int rays_with_reef = 0;          // rays that cross a reef (a cell above kReefEdgeM)
  double crest_median_m = NAN;     // median over those rays of the crest height
  double crest_at_sea = 0;         // share of those rays whose crest ≥ kCrestAtSeaM
  double reef_flat_width_m = NAN;  // median width of the run of cells in [−2, +1] m around the crest
  double lagoon_median_m = NAN;    // median height of water cells inward of the crest (before land)
  double lagoon_min_m = NAN;       // the deepest of them
  int passes = 0;                  // runs of rays whose crest < kPassCrestM between reef rays
  int motu = 0;                    // land components with max height < kMotuMaxHeightM
  std::vector<double> motu_widths_m;  // each motu's width (minor side of its bounding rotated box)
  double flat_floor_share = 0;     // share of the canvas within 0.5 m of its lowest value
  double grid_amplitude_m = NAN;   // Fourier amplitude at the model grid's period on underwater slopes (0 if not asked)
  double grid_ring_ratio = NAN;    // that amplitude / the median amplitude of its ring
};

// grid_period_px > 0 also measures the model grid (the period in pixels, e.g.
// 8 for a 2048² answer of a 256² model): Welch's method over windows 8 periods
// wide that lie ≥ 90 % on underwater slope (−80 … −3 m): the mean amplitude of the
// components at that period along x, y and the diagonals, and its ratio to
// the median of its frequency ring. NaN when no window qualifies.
ReefStats reef_stats(const cv::Mat1f& height_m, double metres_per_px, double grid_period_px = 0);

}  // namespace reefgen::terrain
