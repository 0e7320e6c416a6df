#pragma once
// The realism statistics users and tests measure with (`reefgen realism`,
// docs/REALISM.md). LibTorch-free, deterministic, single-threaded.
#include <cstdint>

#include <opencv2/core.hpp>

namespace reefgen::terrain {

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

}  // namespace reefgen::terrain
