#pragma once
// The realism statistics users and tests measure with (`reefgen realism`,
// docs/REALISM.md). LibTorch-free, deterministic, single-threaded.
#include <cstdint>

#include <functional>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace reefgen::terrain {

// The realism statistics of docs/REALISM.md, for a
// height field in metres with sea level 0.
struct RealismStats {
  int64_t land_cells = 0;    // h > 0
  int64_t flank_cells = 0;   // land with 10–90 % of the highest land height; none below kFlankMinPeakM
  double max_height_m = 0;
  double pits = 0;      // share of land cells in closed depressions deeper than 1 m
  double terraces = 0;  // share of flank cells with slope < 2°
  double valleys = 0;   // share of flank cells that are convergent (plan curvature < −1e-3 1/m on
                        // heights smoothed by a Gaussian of σ = 60 m, where the gradient > 0.02)
  double seams_rows = 0;  // seam_score along rows (a horizontal border between row r and r+1); 0 = no land
  double seams_cols = 0;  // the same along columns (a vertical border)
};

// The statistics as every report writes them (realism --json, erode's
// sidecar, bench realism, Python's reefgen.realism): one key per field,
// named as the field.
void to_json(nlohmann::json& j, const RealismStats& s);

// A canvas whose highest land is lower than this has no flank, metres: its
// land is motu, sand cays or a reef islet (real motu 1–4 m, docs/REEF.md),
// flat by nature and too low for valleys, so its terraces and valleys are
// not judged (a painted atoll's seeded motu would count as a canvas of
// flats without valleys).
inline constexpr double kFlankMinPeakM = 20;

// Rows (or columns) that hold fewer than this share of the busiest row's land
// cells are left out of the seam profile: a coast's few cells give a noisy median.
inline constexpr double kSeamMinRowShare = 0.25;
// Half-width of the running median a row's step is compared with (rows): wider
// than a seam, narrower than an island's change of relief.
inline constexpr int kSeamWindowRows = 16;

// The seam statistic of docs/REALISM.md: on land, over the rows holding at
// least kSeamMinRowShare of the busiest row's land cells, the profile
// p[r] = median over the cells land in rows r and r+1 of |h[r+1][c] − h[r][c]|;
// the score is max over r of p[r] / (median of p over r ± kSeamWindowRows).
// A window or tile border shows as one row whose step stands out (a 3 m step
// along one row of an island scores ~12); a seamless field scores 1.5–2.
// along_rows = false scores the columns (the transpose). 0 when no row qualifies.
double seam_score(const cv::Mat1f& height_m, bool along_rows);

// metres_per_px: horizontal size of a cell. Throws reefgen::Error on an empty,
// non-finite field or a non-positive cell size.
RealismStats realism_stats(const cv::Mat1f& height_m, double metres_per_px);

// The same statistics read a band of rows at a time, for a field larger than
// memory (docs/REALISM.md "Streamed"): rows(y0, n) gives rows y0 … y0 + n − 1
// of a field of `size`. Each band is read with halo_rows more on each side:
// terraces, valleys and the row seams are those of realism_stats exactly
// (the σ = 60 m blur's kernel must fit in the halo: it is widened to fit);
// pits are counted with the band's cut edges as outlets, so a depression is
// found when its spill path stays within the halo (a lower bound, exact for
// every depression smaller than the halo); the column seams take each
// column's median from a histogram of kStreamStepBins logarithmic bins
// (within 1 % of the exact median).
struct StreamBands {
  int band_rows = 1024;  // rows a band holds, ≥ 1
  int halo_rows = 256;   // rows read on each side of a band, ≥ 2
};
inline constexpr int kStreamStepBins = 2048;
using RowSource = std::function<cv::Mat1f(int y0, int rows)>;
RealismStats realism_stats_streamed(const RowSource& rows, cv::Size size, double metres_per_px,
                                    const StreamBands& bands = {});

// Plan curvature −(h_xx h_y² − 2 h_xy h_x h_y + h_yy h_x²) / (h_x² + h_y²)^{3/2}
// (1/m; negative = convergent, a valley) and gradient magnitude (m/m) by
// central differences, on heights already smoothed by the caller.
void plan_curvature(const cv::Mat1f& smooth_m, double metres_per_px, cv::Mat1f& curvature, cv::Mat1f& gradient);

// How far heights keep to the sketch they were drawn from (the bars,
// docs/REALISM.md): the painted land (island and beach regions) above the
// sea, and the painted bright abyss (abyss with λ below kBrightAbyssMaxLambda)
// deeper than kAbyssBarDepthM. The sketch's regions and λ may come at any
// resolution over the same ground (read by position, nearest).
inline constexpr double kBrightAbyssMaxLambda = 0.5;
inline constexpr float kAbyssBarDepthM = 20.f;
struct SketchAgreement {
  int64_t land_cells = 0, abyss_cells = 0;  // painted, at the heights' resolution
  int64_t land_up = 0, abyss_deep = 0;      // of those, above the sea / below −kAbyssBarDepthM
  double land_above_sea = 1;                // land_up / land_cells (1 when there are none)
  double abyss_below_bar = 1;               // abyss_deep / abyss_cells (1 when none)
};
SketchAgreement sketch_agreement(const cv::Mat1f& height_m, const cv::Mat1b& region, const cv::Mat1f& subsidence);
// The same a band at a time: `band` is rows row0 … of a field of `size`.
void add_sketch_agreement(SketchAgreement& a, const cv::Mat1f& band, int row0, cv::Size size, const cv::Mat1b& region,
                          const cv::Mat1f& subsidence);

}  // namespace reefgen::terrain
