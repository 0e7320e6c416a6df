#pragma once
// How far an island is dissected (docs/REALISM.md "Age and dissection"): the
// two measures O'Hara et al. (Earth Surface Dynamics 12:709, 2024) find to
// track a volcanic edifice's age — drainage density and hypsometry. A young
// shield is a convex cone cut by shallow radial gullies (few valleys, much
// of its land high); an old island is cut by deep valleys down to the sea
// (many valleys, little land high). LibTorch-free, deterministic.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace reefgen::terrain {

// The drainage density is read as O'Hara et al.'s DrainageVolc reads it: on
// a grid of kDissectionGridM cells (theirs; finer fields are averaged down,
// so the figure does not depend on the output's size), with channels where
// the drainage area passes the break of the island's own slope–area
// relation (Montgomery & Foufoula-Georgiou 1993): slope rising or flat with
// area on hillslopes and unchannelled flanks, falling as A^−θ in channels. A
// young shield's flanks stay hillslope-like far down (a large threshold, few
// channels); an old island's valleys begin near the divides.
inline constexpr double kDissectionGridM = 30;
// The slope–area pairs are read along the main stems (upstream along the
// largest donor, from each outlet to a divide) of the basins whose head lies
// in the top 30 % of the island's height: O'Hara et al.'s "top basins".
inline constexpr double kStemHeadShareOfPeak = 0.7;
// The break is searched in steps of 0.02 decades of area, at least 0.3
// decades from either end of the pairs, with ≥ kBreakMinPairs on each side.
inline constexpr double kBreakStepDecades = 0.02;
inline constexpr double kBreakMarginDecades = 0.3;
inline constexpr int kBreakMinPairs = 10;
// A channel regime is one where slope falls with area: the exponent above
// the break at least this much below the one under it, and negative (a cone
// or a plane, whose slope does not fall with area, has no channels).
inline constexpr double kBreakMinExponentDrop = 0.1;

// The fixed-threshold valley density reefgen reported before the slope–area
// break: channels draining ≥ 0.1 km² that run in a valley (plan curvature
// below kValleyCurvature, 1/m, on heights smoothed by a Gaussian of
// kValleySmoothingM, realism_stats' valley test), on the field's own cells.
// It saturates on any convergent surface (docs/REALISM.md says how).
inline constexpr double kDrainageChannelAreaM2 = 1e5;
inline constexpr double kValleySmoothingM = 60;
inline constexpr double kValleyCurvature = -1e-3;

struct DissectionStats {
  int64_t land_cells = 0;
  double land_km2 = 0;
  double drainage_density_per_km = 0;  // km of channel (A ≥ the slope–area break) per km² of land; 0 without a break
  double channel_threshold_m2 = 0;     // the slope–area break, m²; 0 when the slope never falls with area
  double channel_exponent = 0;         // d log S / d log A above the break (−θ, the concavity)
  double valley_density_per_km = 0;    // the fixed 0.1 km² valley channels per km² of land
  double land_above_half_peak = 0;     // share of land cells higher than half the highest
  double hypsometric_integral = 0;     // mean land height / highest (Strahler 1952: a cone 1/3, a plateau near 1)
};

// The break of a slope–area relation: a continuous two-segment least-squares
// fit of y = log10 S against x = log10 A (a hinge at x = t), t the best on
// the search grid above. Returns false (no channel regime) when no t
// qualifies. Pairs need not be sorted.
struct SlopeAreaBreak {
  double log10_area = 0;
  double exponent_below = 0, exponent_above = 0;
};
bool slope_area_break(const std::vector<double>& log10_area, const std::vector<double>& log10_slope,
                      SlopeAreaBreak& out);

// height_m in metres, sea level 0; metres_per_px the cell size. Channels are
// traced on the Priority-Flood filled surface (steepest descent). Throws
// reefgen::Error on an empty or non-finite field or a non-positive cell size.
DissectionStats dissection_stats(const cv::Mat1f& height_m, double metres_per_px);

}  // namespace reefgen::terrain
