#pragma once
// The network's answer on the open sea, cleaned before amplifying
// (docs/INFERENCE.md "The open sea"). Near the canvas edge: the generator's convolutions pad with zeros, and its answer on the
// outermost cells of an open-sea edge departs from the sea floor it draws
// everywhere else — a step up on the last row and a groove ~1.5 m deep a few
// rows in, which every hill-shade of an output shows as a square frame
// parallel to the edges. The training targets' floor keeps its trend to the
// edge. On open-sea edges only, the band is blended into the floor's own
// trend, read just inside it. LibTorch-free.
#include <opencv2/core.hpp>

namespace reefgen::infer {

struct EdgeRepairParams {
  int band_px = 14;             // cells from the edge blended into the trend, model cells, [0, 64] (0 = off)
  double open_sea_m = -40;      // a line is open sea when every cell of band and fit window is below this, metres
};

// Each line across each edge whose 2·band_px cells lie below open_sea_m gets
// its band (distance d < band_px) blended, with weight 1 over the outer half
// easing to 0 at band_px, into the least-squares line through the next
// band_px cells; the share of lines repaired is eased along the edge, so an
// island reaching the edge keeps its cells and nothing steps beside it. Then
// the open sea of the band is lightly smoothed (the corners, where the two
// edges' fits meet).
// h: heights in metres, any size of at least 2·band_px a side; in place.
void repair_canvas_edges(cv::Mat1f& h, const EdgeRepairParams& p = {});

struct OpenSeaSmoothing {
  double sigma_px = 4;    // Gaussian σ, model cells (94 m), [0, 16] (0 = off)
  double from_m = -20;    // a cell whose neighbourhood (±2σ) reaches above this is not moved, metres
  double full_m = -40;    // fully smoothed where the whole neighbourhood lies below this, metres
  double foot_from_m = -60;  // the fore reef's foot: cells below this are also blurred over the floor alone, metres
  double foot_full_m = -70;  // fully from this depth, metres
};

// The ghost contours of the open sea: an L1-trained network answers the
// fore reef's many possible positions with their average, faint
// contour-parallel steps outside the reef that no training target has
// (relief at σ 4 cells: 0.29 m RMS in the shipped model's deep sea, 0.10 m
// in the targets; docs/INFERENCE.md "The open sea"). A Gaussian smoothing of
// the deep sea, weighted by how deep the cell's whole neighbourhood (±2σ)
// lies: the reef, its fore-reef slope and any land are never moved; the
// floor's broad relief (~1.5 km features) keeps most of its amplitude.
// Within ±2σ of the rim that smoothing stops, and the ripples the network
// draws parallel to the rim on the floor at the fore reef's foot (±0.5–1 m,
// 2–4 cells apart; from above, rings round every painted reef) stayed: the
// floor below foot_from_m is blurred over itself alone (normalised
// convolution over the cells that deep), so the drop above it is neither
// pulled down nor smeared.
void smooth_open_sea(cv::Mat1f& h, const OpenSeaSmoothing& p = {});

struct LagoonSmoothing {
  double sigma_px = 3;    // Gaussian σ, model cells (70 m), [0, 16] (0 = off)
};

// The ghost contours of a painted lagoon: the same averaging leaves faint
// rings parallel to the painted band edges on the lagoon's water and a
// beaded moat where the lagoon meets the reef band (relief at σ 2 cells
// 0.17 m RMS in the shipped model's painted lagoons; the targets' floors
// have no rings, their relief is noise and patch reefs; docs/INFERENCE.md
// "The open sea"). The water of the painted lagoon and reef bands (labels
// kLagoon and kReef, h < 0) is replaced by its own Gaussian mean
// (normalised over that water, so the land does not pull it up), eased in
// over 2σ from the water's edge: the coast, the fore reef's drop to the
// open sea and the edge cells never move, and no water comes above the sea.
// The crest, the motu and the patch reefs are finished after
// (reef_finish.hpp). label: region per cell, the size of h.
void smooth_lagoon_floor(cv::Mat1f& h, const cv::Mat1b& label, const LagoonSmoothing& p = {});

}  // namespace reefgen::infer
