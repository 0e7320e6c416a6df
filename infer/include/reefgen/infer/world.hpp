#pragma once
// Worlds: a sketch of any size and aspect read at the model's own
// scale (a pixel is 23.4 m unless the user says otherwise), answered by the
// generator in one pass over the whole sketch (docs/WORLDS.md: why one pass
// and not windows).
#include <opencv2/core.hpp>

#include "reefgen/infer/infer.hpp"
#include "reefgen/labels.hpp"

namespace reefgen::infer {

// Reflected margin round a world sketch before its pass, px at the model's
// scale: an island crossing the border continues past it instead of meeting
// the network's zero padding (one receptive-field-wide band at the bottleneck
// would be 256; 64 measured enough, docs/WORLDS.md).
inline constexpr int kWorldMarginPx = 64;
// The largest side one pass takes, px at the model's scale (the oneDNN
// engine's plan; ~9 GB of activations at fp32): 96 km at 23.4 m.
inline constexpr int kMaxWorldPassPx = 4096;

// Islands whose equivalent radius (√(area/π) of the painted, non-abyss
// region) passes this, px at the model's scale, are larger than the islands
// the model learned from (reef radius ≤ ~0.55 of the 128 px half-canvas,
// with the spread of the random specs): they get a second, coarse pass.
inline constexpr double kLargeIslandRadiusPx = 100;
// The radius a large island is shrunk to for its coarse pass, px: a typical
// training island, so the model draws one massif with its summit in the core.
inline constexpr double kCoarseIslandRadiusPx = 75;
// How far the coarse answer fades into the whole-sketch pass round a large
// island, px at the model's scale: its mask is blurred by a Gaussian of half
// of this (σ 16 px, 375 m).
inline constexpr double kCoarseFadePx = 32;

// Painted land stays land: where a world's sketch paints island or beach,
// heights are at least kPaintedLandFloorM, rising from kPaintedCoastFloorM on
// the painted coast over kPaintedLandRampPx px (model scale); where that
// raised a coast the network drew inland, a shoreface (2 %, then a 17 %
// fore-slope to the sea floor) runs through the painted coast smoothed over
// a model cell, so the kept coast is a curve, not the painted staircase of
// cells. The network sinks the land of subsided islands (atoll islets, a
// barrier reef's beaches) as the paper's generator does; a painter wants it
// above the sea (docs/WORLDS.md: 94.6 % of a 2048² archipelago's painted
// land was).
inline constexpr float kPaintedCoastFloorM = 0.05f, kPaintedLandFloorM = 1.0f;
inline constexpr double kPaintedLandRampPx = 2;
// Raises `height_m` to the floor above on the painted land of `label` (same size).
void keep_painted_land(cv::Mat1f& height_m, const cv::Mat1b& label);

// The generator's heights (m) over the whole sketch, at the model's scale:
// sketch_metres_per_px / kModelMetresPerPx times the sketch's size. The
// sketch is resampled to that scale (regions by nearest neighbour,
// subsidence bilinear), given a reflected margin, padded with abyss (λ from
// the edge) to a square multiple of 2^depth, answered in one forward and cropped back.
// An island larger than kLargeIslandRadiusPx is answered by a coarse pass
// of the island alone at kCoarseIslandRadiusPx (the whole-sketch pass draws
// it as a plateau ringed by ridges, with no summit): the coarse answer,
// upsampled, replaces the first one over the island's blurred mask, faded in
// with the island's size (docs/WORLDS.md).
// The answer is the network's (no clean-up); o's engine, precision and
// modes apply. Throws reefgen::Error past kMaxWorldPassPx.
cv::Mat1f world_model_heights(model::GeneratorFile& g, const DecodedSketch& sketch, double sketch_metres_per_px,
                              const InferOptions& o);

}  // namespace reefgen::infer
