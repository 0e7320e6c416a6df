#pragma once
// The model's answer finished (docs/EROSION.md, "At the model's side"):
// ponds of sea inside land raised, pits drained, and above the model's side
// the answer amplified with the generator's refinement. LibTorch-free.
#include <cstdint>
#include <functional>

#include <opencv2/core.hpp>

#include "reefgen/infer/amplify_params.hpp"

namespace reefgen::infer {

// Low land keeps a little relief of its own (beach ridges and swales on a
// coastal plain, the berm of a motu): up to kLowlandReliefM, fading out by
// kLowlandTopM, one feature every kLowlandFeaturePx cells (~23 m at a
// world's 2.9 m cells: beach cusps, berms and dunes are 0.5–2 m over
// 20–50 m). The amplification's fractal detail fades with height (a fifth
// at 1 m) and the land's floor holds what erosion cut to base level, so
// low land was dead flat: long straight flat strips, and graded (grade_land)
// a featureless cone round every island. Only added, never taken (a dip
// would be clamped flat at the land's floor); its hollows are shallower than
// kPitDepthM, so no pit is drained for them. Rows are numbered from y0 (a
// band's first row in its field), so bands of one field agree.
inline constexpr float kLowlandReliefM = 0.3f;
inline constexpr float kLowlandTopM = 3.f;
inline constexpr float kLowlandFeaturePx = 8.f;
void add_lowland_relief(cv::Mat1f& height_m, int y0, uint64_t seed);

// Amplification of a coarse height field (a 256² model answer) to size×size
// (infer --size N): the coarse field's land is roughened (AmplifyParams::roughness)
// and eroded once on its own grid (pits
// filled by sediment, valleys the model smoothed re-carved), then refined
// level by level as the generator refines its own islands, with fractal
// detail noise (amplitude ∝ cell size) standing in for the render's finer
// detail. Only land moves; the sea is the coarse answer, bicubic, except
// the small ponds of sea enclosed by land (AmplifyParams::pond_max_m2), which
// become land. label: the sketch's regions at
// size×size. lowland_relief: add_lowland_relief before the grading (false
// for a world's level below its banded last doubling, which adds it after
// each band's draining: a level's bumps, doubled, made depressions deeper
// than a pit that bands of different heights drained differently).
// ruggedness: the sketch's per-region style (DecodedSketch::ruggedness, any
// side; empty or all 255 = rugged everywhere, the same bytes as without it):
// where it is lower the lobes, the roughening and the finer levels' detail
// shrink and the ground erodes as harder rock (docs/INFERENCE.md
// "Per-region style").
cv::Mat1f amplify_heights(const cv::Mat1f& coarse_m, const cv::Mat1b& label, double world_size_m, uint64_t seed,
                          const AmplifyParams& p = {}, bool lowland_relief = true,
                          const cv::Mat1b& ruggedness = {});

// The style blends over this distance (Gaussian σ, m): a brush's edge, JPEG
// and anti-aliasing do not print as steps in the relief.
inline constexpr double kStyleBlendM = 400;
// What a smooth shield keeps of the finer levels' detail (lava surfaces,
// scoria: not a polished dome).
inline constexpr float kSmoothDetailShare = 0.35f;
// The style at side×side in [0, 1], blended (kStyleBlendM); empty when the
// sketch is rugged everywhere.
cv::Mat1f ruggedness_at(const cv::Mat1b& ruggedness, int side, double world_size_m);

// The land's relief the roughening follows (AmplifyParams::relief_reach_m):
// each land cell's height over the lowest land within reach_m (a square
// window, its lowest value softened by a Gaussian of a quarter of the
// reach), clamped to [0, h]; exactly its height where the window reaches
// the sea. Empty when reach_m ≤ 0 (the roughening then follows the height).
// h: heights (m), cell_m: metres per cell.
cv::Mat1f local_relief(const cv::Mat1f& h, double cell_m, double reach_m);

}  // namespace reefgen::infer

namespace reefgen::infer {

// The largest side amplify_heights refines in one piece, px: its working
// copies and flow graph peak at 5.2 GB at 8192² (docs/WORLDS.md).
inline constexpr int kMaxWholeAmplifySidePx = 8192;
// A world's last doubling is refined in bands of this many rows, with
// kWorldBandHaloPx rows of halo above and below for the pit draining: memory
// stays a band's, whatever the side.
inline constexpr int kWorldBandRowsPx = 1024;
inline constexpr int kWorldBandHaloPx = 64;
// The largest side amplify_world makes, px: 16385² float32 is 1.07 GB, the
// whole world stays in memory once (docs/WORLDS.md).
inline constexpr int kMaxWorldSidePx = 16385;

// A world (a model-scale answer, world_model_heights) amplified to `size`
// samples along its longer side (a world that is not square is padded with
// open sea to a square and cropped back). Up to kMaxWholeAmplifySidePx this is amplify_heights. Beyond,
// amplify_heights refines the whole world to the last refinement level
// below `size` (erosion and routing on the whole field, so rivers cross any
// later tile border), then the last doubling is made in bands of rows: the
// bicubic upsampling and the fractal detail are functions of a cell's
// position only, and each band's closed depressions are drained with a halo
// of kWorldBandHaloPx rows. label: the regions at the model's scale (any
// side; resampled). progress(done, total) is called after each band.
// The sizes amplify_world switches and bands at (tests use tiny ones).
struct WorldBands {
  int whole_max_px = kMaxWholeAmplifySidePx;  // amplify_heights in one piece up to this side
  int rows_px = kWorldBandRowsPx;             // rows of a band of the last doubling, ≥ 1
  int halo_px = kWorldBandHaloPx;             // rows of halo a band's pit draining sees, ≥ 0
};
cv::Mat1f amplify_world(const cv::Mat1f& coarse_m, const cv::Mat1b& label, int size, double world_size_m,
                        uint64_t seed, const AmplifyParams& p = {},
                        const std::function<void(int, int)>& progress = {}, const WorldBands& bands = {},
                        const cv::Mat1b& ruggedness = {});

}  // namespace reefgen::infer
