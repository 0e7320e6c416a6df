#pragma once
// How far an island is dissected (docs/REALISM.md "Age and dissection"): the
// two measures O'Hara et al. (Earth Surface Dynamics 12:709, 2024) find to
// track a volcanic edifice's age — drainage density and hypsometry. A young
// shield is a convex cone cut by shallow radial gullies (few valleys, much
// of its land high); an old island is cut by deep valleys down to the sea
// (many valleys, little land high). LibTorch-free, deterministic.
#include <cstdint>

#include <opencv2/core.hpp>

namespace reefgen::terrain {

// A channel drains at least this area, m² (0.1 km²: a first-order stream on
// a volcanic island's flank; a size in metres, so the measure does not
// depend on the cell size).
inline constexpr double kDrainageChannelAreaM2 = 1e5;
// A channel is counted where it runs in a valley: plan curvature below
// kValleyCurvature (1/m) on heights smoothed by a Gaussian of
// kValleySmoothingM (realism_stats' valley test), so flow lines down a
// smooth cone are not valleys.
inline constexpr double kValleySmoothingM = 60;
inline constexpr double kValleyCurvature = -1e-3;

struct DissectionStats {
  int64_t land_cells = 0;
  double land_km2 = 0;
  double drainage_density_per_km = 0;  // km of valley channel per km² of land
  double land_above_half_peak = 0;     // share of land cells higher than half the highest
  double hypsometric_integral = 0;     // mean land height / highest (Strahler 1952: a cone 1/3, a plateau near 1)
};

// height_m in metres, sea level 0; metres_per_px the cell size. Channels are
// traced on the Priority-Flood filled surface (steepest descent). Throws
// reefgen::Error on an empty or non-finite field or a non-positive cell size.
DissectionStats dissection_stats(const cv::Mat1f& height_m, double metres_per_px);

}  // namespace reefgen::terrain
