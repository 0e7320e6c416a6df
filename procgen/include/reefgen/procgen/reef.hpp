#pragma once
// Reef geomorphology after the paper's coral growth (docs/REEF.md): each
// piece a named step over the generator's per-pixel fields, each with the
// real-reef figures it follows in its doc comment. LibTorch-free.
#include <array>
#include <cmath>
#include <vector>

#include <opencv2/core.hpp>

#include "reefgen/procgen/spec.hpp"

namespace reefgen::procgen {

class OutlineTable;

// Step 6, the sea floor beyond the reef: from the rim's edge (foot_m,
// −rim_edge_depth_m) the flank falls kFlankSteepFallM, or 1 − kFlankTailShare of
// the way to a shallower floor (from −60 m to the −100 m floor: 29 m), as
// 1 − tanh(d / decay_m) — steepest at the top (29 m over 35 m: 40°), then
// relaxing — and the rest towards the floor e-folding over kFlankFarDecayM,
// never reaching it (a floor reached a few hundred metres out was a flat
// plane over the canvas), with low relief (n ∈ [−1, 1], fbm over
// kAbyssReliefFeatureM) that grows in over kAbyssReliefRiseM from the reef.
// d_m: distance from the rim's outer edge. Also what augment::redraw_flank
// draws after augmentation.
inline constexpr double kAbyssReliefFeatureM = 1500;
inline constexpr double kAbyssReliefRiseM = 300;
inline constexpr double kFlankSteepFallM = 60, kFlankFarDecayM = 900, kFlankTailShare = 0.25;
inline double flank_height_m(double d_m, double floor_m, double foot_m, double decay_m, double relief_m, double n) {
  const double fall = foot_m - floor_m - 1.0, far = std::max(kFlankTailShare * fall, fall - kFlankSteepFallM);
  const double base = floor_m + 1.0 + far * std::exp(-d_m / kFlankFarDecayM) + (fall - far) * (1.0 - std::tanh(d_m / decay_m));
  const double relief = relief_m * (0.5 + 0.5 * n) * (1.0 - std::exp(-d_m / kAbyssReliefRiseM));
  return base + relief;
}

// Deepest floor (m, positive) of a mature lagoon of `area_km2` (the area
// inside the reef). Purdy & Winterer (2001, 301 atolls): lagoon depth grows
// with atoll area, typically 20–60 m, up to ~90 m; this fit gives 18 m at
// 1 km², 30 m at 10 km², 42 m at 100 km², 54 m at 1000 km², clamped to [8, 90].
double lagoon_depth_for_area_m(double area_km2);

// The lagoon depth of an island: the spec's, or the fit above from the area
// inside the outline R_3 (the lagoon's outer border), scaled for age: a
// fringing reef's back-reef (λ = 0) is young_lagoon_share of it, a barrier
// reef's lagoon (λ ≥ kBarrierLambda) all of it.
inline constexpr double kBarrierLambda = 0.3;
// The back-reef toe sits at this share of the lagoon depth: the basin's floor
// next to the reef (apply_reef's floor is 0.75 D there, D in its middle).
inline constexpr double kBackReefShare = 0.75;
double lagoon_depth_m(const IslandSpec& spec);

// The land's descent to the lagoon shore at x̃ = 2 and the lagoon's shoreface,
// a function of x̃ alone (tabulated with the profile): land heights are scaled
// to 0 between coast_begin and x̃ = 2 (a coast, not a cliff), and past x̃ = 2
// nothing stands above the shoreface −D·s((x̃ − 2)/shoreface): a painted
// lagoon is water at every age ("behind a reef crest lies water").
double shore_height_m(double h_m, double xt, double depth_m, const ReefParams& r);

// The rim's zones across the band between the outlines R₃ (the lagoon's
// border) and R₄ (the rim's outer edge), metres, seaward to lagoonward
// (docs/REEF.md "Reef proportions"): the fore-reef terrace, the crest, the
// flat, the back-reef slope down to the lagoon. They add up to the band.
struct RimWidths {
  double fore = 0, crest = 0, flat = 0, back = 0;  // fore: the drop-off and the terrace above it
};
// The rim's seaward edge (R₄) lies kRimEdgeDepthM deep: the drop-off from
// the terrace's foot (fore_reef_depth_m) down to it is part of the rim, over
// kDropOffWidthM, so every abyss-labelled cell is open ocean (below −60 m,
// as terrain::deepen_flank and the dataset's wrap check read it).
inline constexpr double kRimEdgeDepthM = 60, kDropOffWidthM = 60;
// The rim's depth at R₄ (m, positive): kRimEdgeDepthM, or deeper than a
// terrace whose foot lies deeper still.
inline double rim_edge_depth_m(const ReefParams& r) { return std::max(kRimEdgeDepthM, r.fore_reef_depth_m + 1.0); }
// The back-reef slope is never narrower than this (m): from the flat down
// to the lagoon's edge, 15–40 m at the lagoon depths of kBackReefShare, at
// most ~30° over it (60 m drew the lagoon's edge as a dark line in a
// hill-shade).
inline constexpr double kMinBackReefM = 100;
// The widths on a band band_m wide, facing ∈ [−1, 1] the cosine of the
// angle from windward: the flat is flat_width_m × (1 + windward_flat_gain ·
// facing) where the band has room; a narrower band narrows the flat first,
// then every zone in proportion; a wider one widens the back-reef slope.
RimWidths rim_widths_m(double band_m, double facing, const ReefParams& r);

// Coral height (m) at s metres lagoonward of R₄ (0 ≤ s ≤ the band): the
// drop-off rises from −rim_edge_depth_m at R₄ to −fore_reef_depth_m over
// the first kDropOffWidthM (~42° at R₄, easing into the terrace's slope),
// the fore-reef terrace rises from there to the crest as (1 − t)^1.5
// (~10° at its foot, flat at the crest), then the crest at crest_m +
// crest_relief_m, the flat at flat_m + flat_relief_m turning up into the
// crest over its first quarter, and the back-reef slope down to back_m at R₃.
double rim_height_m(double s, const RimWidths& w, const CoralParams& c, double back_m, const ReefParams& r,
                    double crest_relief_m, double flat_relief_m);

// Segments per bounding box of a pass's centre line: a drawn pass of 1024
// points is 8000 segments, and most boxes are far from a given cell.
inline constexpr int kPassChunk = 16;

// Everything the reef steps need per island, placed once from the spec.
struct ReefPlan {
  double depth_m = 0;              // lagoon depth D (m, positive)
  std::array<double, 2> windward;  // unit vector towards the wind's origin (canvas, +y up)
  struct Pass {
    std::vector<std::array<float, 4>> segs;  // canvas segments: x0, y0, x1, y1
    double half_width = 0, depth_m = 0;      // canvas units, m
    std::array<float, 4> box{};              // canvas bounding box of the cut (x0, y0, x1, y1), widths included
    std::vector<std::array<float, 4>> chunk_box;  // the same per kPassChunk segments
  };
  std::vector<Pass> passes;
  struct Islet {
    double theta = 0, half_len = 0, half_wid = 0, height_m = 0;  // rad, canvas units, canvas units, m
  };
  std::vector<Islet> motu;
};
ReefPlan plan_reef(const IslandSpec& spec, const OutlineTable& outlines);

// The per-pixel fields the reef steps read besides the heights before the
// merge (the volcano, eroded or not): x̃ and each pixel's source point (the
// wind-warped canvas point its material came from). The coral is the rim's,
// grown by apply_reef itself.
struct ReefInputs {
  const cv::Mat1f& xt;
  const cv::Mat2f& source;  // canvas (x, y) of each pixel's material
};

// The steps, in order, on one height field (label updated where motu or
// passes change the region):
//  1. lagoon floor: sunk ground is filled to the basin floor, deepest in the
//     middle, with patch reefs and pinnacles rising from it;
//  2. passes cut the coral rim to their floor;
//  3. coral growth: the smooth maximum of the ground and the coral (Eq. 9);
//  4. motu on the reef flat (beach label where above sea);
//  5. spur-and-groove on the windward fore reef (visible from ~4 px a period);
//  6. the sea floor beyond the reef descends with relief, never flat.
void apply_reef(cv::Mat1f& height_m, cv::Mat1b* label, const ReefInputs& in, const IslandSpec& spec,
                const OutlineTable& outlines, const ReefPlan& plan);

}  // namespace reefgen::procgen
