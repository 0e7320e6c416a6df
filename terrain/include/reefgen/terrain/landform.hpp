#pragma once
// How a volcanic island's valleys are organised (docs/REALISM.md "Drainage
// organisation"): the figures that tell a stamped sunburst of equal radial
// valleys from a real island, where a few large basins capture many small
// ones, spacing is irregular and the wet side is cut deeper. Scale-free: the
// field is read on a grid of about kLandformCells across the island, so a
// 4 km² preset and Kauaʻi's 1430 km² are compared on the same footing.
// LibTorch-free, deterministic.
#include <opencv2/core.hpp>

namespace reefgen::terrain {

// Cells across the island's equivalent diameter (2·√(area/π)) the measure
// reads it on; a coarser field is read as it is.
inline constexpr double kLandformCells = 300;
// Valleys are minima of the heights less their Gaussian blur of this share of
// the diameter (wider than a valley, narrower than the flank's curve).
inline constexpr double kDetrendShareOfDiameter = 0.04;
// A valley on a circle is the lowest point within kValleyWindowShareOfDiameter
// either side (2 cells at kLandformCells) and at least this deep below the
// lower of the highest points within that window either side, as a share of
// the island's highest point: SRTM's noise on Kauaʻi
// (±5 m) and a generator's 1-px grain are not valleys.
inline constexpr double kValleyProminenceShareOfPeak = 0.004;
inline constexpr double kValleyWindowShareOfDiameter = 0.007;
// Circles at these shares of the summit-to-coast distance.
inline constexpr double kCircleShares[3] = {0.4, 0.6, 0.8};
// Angular sectors round the summit for the wind's mark on the dissection.
inline constexpr int kSectors = 16;
// The angular power spectrum's band (cycles round the circle): below 6 the
// island's shape, above 80 the grain.
inline constexpr int kSpectrumFirst = 6, kSpectrumLast = 80;
// Valleys for "basins capturing others": channels draining at least this
// share of the island's land.
inline constexpr double kValleyAreaShare = 0.002;
// Valley depth: the heights' grey closing with a disc of this share of the
// diameter, less the heights (valleys narrower than twice it are bridged, as
// the surface they were cut into; 300 m on the presets' 3 km islands, 5 km
// on Kauaʻi), read over land above kValleyDepthLandShareOfPeak of the peak
// (the coastal plain is no valley).
inline constexpr double kValleyDepthDiscShareOfDiameter = 0.1;
inline constexpr double kValleyDepthLandShareOfPeak = 0.02;
// Where a valley is for the windward / leeward comparison: deeper than this
// share of the peak (a gully, not the grain).
inline constexpr double kValleyCellShareOfPeak = 0.01;

struct LandformStats {
  double spacing_cv = 0;           // coefficient of variation of the valleys' spacing on the circles (mean of the three)
  double spectrum_peak_ratio = 0;  // the circles' angular power spectrum over its power-law fit: peak / median (mean of the three)
  double sector_cv = 0;            // coefficient of variation of the dissection (RMS detrended relief) over the sectors
  double hack_exponent = 0;        // h in L ∝ A^h: main-stream length against drainage area over the land's channels
  double valleys_per_basin = 0;    // valley heads (kValleyAreaShare) per coastal basin that holds one
  int valleys_on_circles = 0;      // minima counted on the three circles
  double valley_depth_p90_m = 0;   // 90th percentile of the valley depth over land (closing less heights), m
  // With a wind (wind_from_deg ≥ 0): the median valley depth on the
  // windward half (cells whose bearing from the summit is within 90° of
  // where the wind comes from) over the leeward half's; 0 without a wind or
  // a valley on either half.
  double windward_depth_ratio = 0;
  double cell_m = 0;               // the grid it was read on
};

// height_m in metres, sea level 0, metres_per_px the cell size; rows run
// south (north up, as the generator and GIS draw them); wind_from_deg the
// compass bearing the wind comes from, or < 0 for none. Throws
// reefgen::Error on an empty or non-finite field, a non-positive cell size
// or a field with too little land to read (fewer than 100 cells).
LandformStats landform_stats(const cv::Mat1f& height_m, double metres_per_px, double wind_from_deg = -1);

}  // namespace reefgen::terrain
