#pragma once
// Fluvial erosion that carves a drainage network (docs/EROSION.md):
//   ∂h/∂t = −K(ρ) A^m S + D ∇²h   on land (h > 0), base level = sea level
// the stream-power law solved implicitly along the drainage tree (Braun &
// Willett 2013: O(n) per step, stable at any time step), water routed out of
// closed depressions by Priority-Flood (Barnes et al. 2014), hillslope
// diffusion as its exact Gaussian solution per step. Erodibility comes from
// the paper's resistance map: hard volcanic core, soft beach and lagoon.
//
// Multi-scale: the drainage network is carved on a base grid (base_px cells
// across the canvas, 256 = the training resolution), then each finer level
// (×2 up to the output size) adds the detail the coarser level could not hold
// and runs a few short steps that re-incise the channels at its own cell size.
// So a 4097² island is the 256² island with finer valleys, not another island,
// and the same refinement amplifies a 256² model answer (infer --size N).
//
// Only land moves: the sea, the lagoon and the reef keep their heights (coral
// growth is applied after erosion). Deterministic and single-threaded.
//
// erode_level is the composition of the pieces of flow.hpp (routing),
// drainage.hpp (drainage area) and eroders.hpp (stream power, diffusion);
// pits.hpp drains what is left.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reefgen/params_json.hpp"

namespace reefgen::terrain {

struct ErosionParams {
  bool enabled = true;                // false: the paper's uneroded island
  double k_fluvial = 1e-6;            // stream-power erodibility K of soft rock (ρ = 0), m^(1−2m)/yr, [0, 1]
  double m_area = 0.8;                // drainage-area exponent m (slope exponent n = 1), [0.1, 1]
  double hard_erodibility = 0.15;     // K at ρ = 1 as a share of K at ρ = 0, [0, 1]
  double diffusivity = 0.005;         // hillslope diffusion D, m²/yr, [0, 100]
  double duration_yr = 1.5e5;         // time eroded on the base grid, yr, [0, 1e8]
  int steps = 8;                      // implicit steps on the base grid, [0, 1000]
  int base_px = 256;                  // cells of the base grid across the 6 km reference canvas (a wider canvas has more: 23.4 m cells), [16, 8192]
  int trunk_px = 64;                  // cells of the trunk grid across the 6 km canvas, eroded first so that a few large basins capture the base grid's valleys (94 m cells; 0 or ≥ base_px: none), [0, 8192]
  double trunk_share = 0.55;          // share of duration_yr eroded on the trunk grid (the base grid erodes the rest), [0, 1]
  int refine_steps = 3;               // implicit steps at each finer level, [0, 100]
  double refine_duration_yr = 1.5e4;  // time at the first finer level (halved at each next one), yr, [0, 1e8]
  double refine_diffusivity_scale = 0.3;  // hillslope diffusivity at the finer levels, multiple of diffusivity, [0, 1]
  double refine_detail_scale = 2;     // amplitude of the detail added at each finer level, multiple of the default, [0, 10]
  bool refine_random_receivers = true;   // finer levels drain to a lower neighbour drawn ∝ slope², not the steepest (no grid-aligned rills)
  double refine_upsample_sigma = 0.35;   // blur after each level's bicubic upsampling, in coarser cells (0: none; the cells' waffle), [0, 2]
  double noise_amplitude = 0.25;      // relative low-frequency modulation of the resistance, [0, 1]
  double flow_exponent = 1.0;         // multiple-flow-direction share ∝ slope^p (Quinn et al.: 1; large = one direction), [0, 10]
  double pit_breach_m = 5;            // closed depressions left at the end: breached up to this depth, filled below it (0: filled flat), m, [0, 100]
  double channel_head_m2 = 0;         // drainage area where incision begins (above it hillslopes only diffuse; 0: every cell incises), m², [0, 1e8]
  double rain_erodibility_exponent = 0;  // K × (runoff / its land mean)^this where the wind brings rain: wetter rock weathers deeper and incises faster (Ferrier et al. 2013), [0, 4]
};

// The one field list (common/params_json.hpp): JSON both ways and the ranges.
template <class F>
void fields(ErosionParams& p, F&& f) {
  f("enabled", p.enabled);
  f("k_fluvial", p.k_fluvial, Range{0, 1});
  f("m_area", p.m_area, Range{0.1, 1});
  f("hard_erodibility", p.hard_erodibility, Range{0, 1});
  f("diffusivity", p.diffusivity, Range{0, 100});
  f("duration_yr", p.duration_yr, Range{0, 1e8});
  f("steps", p.steps, Range{0, 1000});
  f("base_px", p.base_px, Range{16, 8192});
  f("trunk_px", p.trunk_px, Range{0, 8192});
  f("trunk_share", p.trunk_share, Range{0, 1});
  f("refine_steps", p.refine_steps, Range{0, 100});
  f("refine_duration_yr", p.refine_duration_yr, Range{0, 1e8});
  f("refine_diffusivity_scale", p.refine_diffusivity_scale, Range{0, 1});
  f("refine_detail_scale", p.refine_detail_scale, Range{0, 10});
  f("refine_random_receivers", p.refine_random_receivers);
  f("refine_upsample_sigma", p.refine_upsample_sigma, Range{0, 2});
  f("noise_amplitude", p.noise_amplitude, Range{0, 1});
  f("flow_exponent", p.flow_exponent, Range{0, 10});
  f("pit_breach_m", p.pit_breach_m, Range{0, 100});
  f("channel_head_m2", p.channel_head_m2, Range{0, 1e8});
  f("rain_erodibility_exponent", p.rain_erodibility_exponent, Range{0, 4});
}
// The canvas the erosion's constants are tuned on, m: the presets' and the
// training set's 6 km. erode_island holds an island's erosion the same on a
// canvas of any other width (scaled_to_canvas).
inline constexpr double kReferenceCanvasM = 6000;
// Erosion params for a canvas world_size_m wide that erode an island as they
// do the same island on the 6 km reference canvas, scaled up or down:
//  - the base grid keeps its cell size in metres (base_px × W / 6 km cells,
//    in [16, out_px]): channel heads (m²) and hillslope diffusion (m²/yr) act
//    on the same cells, where 94 m base cells on a 24 km canvas let every
//    cell incise and planed a 5 My island's flanks to a 67 m plain;
//  - K × (6 km / W)^(2m − 1): stream power ∂h/∂t = −K A^m S with n = 1 is
//    unchanged by x → s·x only when m = 1/2 (A → s²A, S → S/s); the law
//    keeps the preset's concavity (m = 0.8) within a canvas and m = 1/2's
//    scale invariance across canvases (a wider island otherwise eroded
//    faster: its time to respond to base level falls as L^(1 − 2m)).
// The identity on the reference canvas (docs/EROSION.md "Island size").
ErosionParams scaled_to_canvas(const ErosionParams& p, double world_size_m, int out_px);

// Channels begin at this contributing area in matured params: above it
// hillslopes only diffuse, so long erosion deepens valleys between ridges
// that stand instead of lowering the whole flank to a plain.
inline constexpr double kMaturedChannelHeadM2 = 5e3;
// The params of an island `maturity` times as eroded (reefgen/age.hpp): the
// time (duration_yr, which the generator and the amplification both scale)
// × maturity, more implicit steps for a longer time (stable at any length,
// but a few coarse strokes cut blunt valley walls), channels beginning at
// kMaturedChannelHeadM2 (infer::matured ages the amplification's own) and,
// above maturity 1, the diffusivity ÷ maturity: the total creep D·t stays
// the unit maturity's, so an old island's time deepens valleys between
// ridges that stay sharp (growing with the age it made a 5 My island's
// interfluves broad and rounded, docs/EROSION.md "Trunk basins"). The
// finer levels keep their time: it is what re-incises the upsampled surface
// at each cell size, and without it a young island's flanks showed the
// coarser levels' cells as a 2 and 4 px waffle at 1025² (docs/EROSION.md).
ErosionParams matured(const ErosionParams& p, double maturity);

void to_json(nlohmann::json& j, const ErosionParams& p);
// Every key optional; unknown keys and out-of-range values throw reefgen::Error naming `origin`.
ErosionParams erosion_params_from_json(const nlohmann::json& j, const std::string& origin);

// One level: `steps` implicit steps sharing `duration_yr` on the land
// (h > 0, at entry) of height_m, in place. erodibility = K per cell
// (m^(1−2m)/yr). Land cells on the canvas edge are outlets (held), like the sea.
// Routing: kFlood = Priority-Flood (closed depressions routed to their spill
// point) with multiple-flow-direction drainage area, the base level's;
// kStack = steepest descent and Braun & Willett's O(n) donor stack, single
// flow direction, for refinement levels whose surface is already drained.
enum class Routing { kFlood, kStack };
// creep_px > 0: after the steps, creep_between_channels with that σ (cells)
// and kChannelAreaM2 (a finer level's hillslopes, docs/EROSION.md "Creep between channels").
// rain_rel (optional, same size): each cell's runoff over the land's mean
// (rain.hpp), so the law's A is the discharge Q = Σ R·a / R̄, and K is
// × rain_rel^rain_erodibility_exponent.
void erode_level(cv::Mat1f& height_m, const cv::Mat1f& erodibility, double metres_per_px, int steps,
                 double duration_yr, const ErosionParams& p, Routing routing = Routing::kFlood, double creep_px = 0,
                 const cv::Mat1f& rain_rel = cv::Mat1f());

// K per cell from a resistance map ρ ∈ [0, 1] modulated by low-frequency
// noise drawn from `seed` (about four features across the canvas, so hard
// and soft bands are not perfect rings).
cv::Mat1f erodibility_map(const cv::Mat1f& resistance, uint64_t seed, const ErosionParams& p);

// `m` upsampled to side×side for the next finer level: bicubic, then a
// Gaussian blur of sigma_cells of m's cells. Bicubic interpolation is C¹
// only: its curvature jumps on every coarse sample line, and where the
// level's erosion left cell-sized incisions a hill-shade shows the coarser
// cells as a waffle (at 1025² the 512² level's 2 px and the base grid's 4
// px; without the finer levels' own erosion the 2 px component stood at 67×
// its ring's median). σ = 0.35 coarse cells (0.7 px at ×2) damps the 2 px
// period to 9 % of its amplitude and keeps 86 % of a feature 4 cells wide.
cv::Mat1f upsampled_level(const cv::Mat1f& m, int side, double sigma_cells);

// Sizes of the refinement chain: from, 2·from, 4·from, … (each < to), to.
std::vector<int> refinement_levels(int from, int to);

// Upsamples `coarse_m` (already eroded at its size) level by level to
// size×size, adding detail(L, upsampled) on land at each level L and eroding
// there (refine_steps steps). resistance is at the final size (resampled to
// each level). Cells that are not land in `land_m` (final size) keep land_m's
// heights; land cells never go below sea level.
// rain_rel (optional, final size): as erode_level's, resampled to each level.
cv::Mat1f refine_heights(const cv::Mat1f& coarse_m, const cv::Mat1f& land_m, const cv::Mat1f& resistance,
                         double world_size_m, uint64_t seed, const ErosionParams& p,
                         const std::function<cv::Mat1f(int, const cv::Mat1f&)>& detail,
                         const cv::Mat1f& rain_rel = cv::Mat1f());

// The trunk grid (docs/EROSION.md "Trunk basins"): `render_m` (the field
// at its own size) averaged to T×T and eroded there for `duration_yr`
// (Priority-Flood routing), returned as the share of each cell's height the
// erosion kept, in [0, 1], carried over the sea by kept_share_over_sea so
// that an upsampling reaches the coast with the land's value.
cv::Mat1f trunk_kept_share(const cv::Mat1f& render_m, const cv::Mat1f& resistance, double world_size_m, uint64_t seed,
                           const ErosionParams& p, int T, double duration_yr, const cv::Mat1f& rain_rel = cv::Mat1f());

// A whole height field eroded at its own size (the generator's islands,
// `reefgen erode` on a user's heightmap): eroded on the base grid
// (Priority-Flood routing) and refined back level by level with the field's
// own finer detail plus fractal detail, then its pits drained. With a
// trunk grid (trunk_px), trunk_share of the time is eroded there first and
// the base grid starts from the render lowered by the share it kept. height_m
// square; resistance ρ ∈ [0, 1] per cell, same size (hard rock erodes at
// hard_erodibility of soft). p is read for the canvas's width
// (scaled_to_canvas): the same island at any world_size_m.
// rain_rel (optional, same size): each cell's rain over the land's mean
// (rain.hpp: the wind's windward wet, leeward dry), read as discharge.
cv::Mat1f erode_island(const cv::Mat1f& height_m, const cv::Mat1f& resistance, double world_size_m, uint64_t seed,
                       const ErosionParams& p, const cv::Mat1f& rain_rel = cv::Mat1f());

// Land never goes below this once it is land (m): smoothing, lobes and
// erosion keep it land (h > 0) so the coastline stays where it was drawn.
constexpr float kLandFloorM = 0.1f;

// side×side by `interpolation`; a copy when the size is already right.
cv::Mat1f resampled(const cv::Mat1f& m, int side, int interpolation);

// Upsampled bicubic to side×side without overshoot: each value stays within
// the bilinear upsampling of the highest and lowest of each source cell's
// 3×3 neighbourhood (continuous bounds: a clamp to the 2×2 cells a sample
// lies between jumps where those cells change, and clamping only where the
// sea level was crossed drew the clamp's outline as a step). Next to a step
// of the model's answer (an 18 m drop from a shoreface into the network's
// moat, a fore reef's drop) the bicubic overshoots by a tenth of the step,
// which stood at 1:1 as a lip of land along the coast or a crest above the
// sea. Where the field is smooth (no overshoot) it is the bicubic itself.
cv::Mat1f upsampled_within_cells(const cv::Mat1f& m, int side);

// Detail a refinement level adds on land at side L (`up`: the level's
// upsampled heights): an fBm tile at 4 cells per feature (3 octaves),
// ± 0.4 cell sizes in metres (relief that grows with the scale, as in
// fractal terrain), faded in over the first 5 m above the sea so that
// coastlines stay where they were. The erosion that follows turns it into
// the heads of small valleys instead of leaving it as noise.
// `up` may be a block of the level whose top-left cell is `origin` (a world
// refined in strips): the detail is a function of the level's coordinates.
cv::Mat1f fractal_detail(int L, const cv::Mat1f& up, double world_size_m, uint64_t seed, cv::Point origin = {0, 0});

// Resistance ρ per region id (0 island … 4 abyss) where only a label map is
// known (a painted sketch): hard volcanic core, soft beach and lagoon, like
// the paper's default resistance curve averaged over each region.
cv::Mat1f resistance_of_labels(const cv::Mat1b& label);

}  // namespace reefgen::terrain
