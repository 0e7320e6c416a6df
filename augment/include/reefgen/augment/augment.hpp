#pragma once
// Augmentation of generated pairs (paper §5, docs/DESIGN.md §4). Every transform is a
// pure function applied identically to the label map, the per-pixel
// subsidence and the heights: labels are never blended (nearest neighbour),
// heights are interpolated (bilinear). No LibTorch here.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace reefgen::augment {

struct Pair {
  cv::Mat1f height_m;    // W×W, metres, sea level 0
  cv::Mat1b label;       // W×W, region ids 0..4
  cv::Mat1f subsidence;  // W×W, λ per pixel (the label map's brightness)
};

// Rotation by angle_deg (counter-clockwise in the image as displayed), uniform
// scaling about the centre, optional horizontal flip (applied first). Pixels
// that come from outside the canvas are open ocean: abyss, their heights the
// canvas edge continued but never above the highest abyss cell on the
// border (`ocean_m` when there are none): a constant floor drew the rotated
// canvas as a step on the sea floor's relief, and replicating alone drew
// streaks wherever an island touched the border.
Pair affine(const Pair& p, double angle_deg, double scale, bool flip_x, double ocean_m = -100.0);

// The generator's sea floor beyond the reef (procgen::flank_height_m), in
// metres: from the fore-reef foot it descends towards the floor, e-folding
// over decay_m, with low relief that grows in over the first few hundred
// metres.
struct FlankShape {
  double metres_per_px = 6000.0 / 256;  // the canvas's cells
  double floor_m = -100;                // the abyss floor (the spec's heights.floor_m)
  double foot_m = -60;                  // the rim's seaward edge (-procgen::rim_edge_depth_m; coral.abyss_m without the reef)
  double decay_m = 35;                  // reef.abyss_decay_m
  double relief_m = 4;                  // reef.abyss_relief_m
};

// The pair's abyss redrawn in its own canvas: every abyss cell gets the
// flank of `f` at its distance from the nearest cell that is not abyss, with
// the relief drawn from `seed`. Drawn after the affine and wrap-around steps,
// the descent no longer stretches with their random scale (which a sketch
// does not show), and the canvas edges those steps move inwards leave no
// seams or straight steps on the sea floor (docs/DATASET.md "The sea
// floor"). Other cells are unchanged; a pair with no abyss is returned as is.
Pair redraw_flank(const Pair& p, const FlankShape& f, uint64_t seed);

// Translation by (dx, dy) pixels with wrap-around: what leaves one side comes
// back on the other. dx > 0 moves content right, dy > 0 down.
Pair translate_wrap(const Pair& p, int dx, int dy);

// Intersection over union of two masks (0 when both are empty).
double iou(const cv::Mat1b& a, const cv::Mat1b& b);

// Footprint of an island: every pixel that is not abyss.
cv::Mat1b footprint(const Pair& p);

struct PasteResult {
  Pair pair;
  int placed = 0;                 // islands that found a place
  std::vector<cv::Point> offsets; // wrap-around shift of each placed island
};

// Copy-paste of several islands into one sample. Island i is tried at up to
// `tries` wrap-around offsets drawn from `seed`; it is kept at the first whose
// footprint IoU with every island already placed is ≤ max_iou. Heights merge
// with the smooth maximum (k in 1/m), the label (and subsidence) comes from
// the island that is higher at that pixel, pixels no footprint covers are abyss.
PasteResult copy_paste(const std::vector<Pair>& islands, uint64_t seed, double max_iou = 0.10, int tries = 64,
                       double smax_k = 0.5);

}  // namespace reefgen::augment
