#pragma once
// The layers of a world too large to hold whole (docs/LAYERS.md, "Worlds"):
// what depends on the whole field — the drainage area, the sediment the flow
// carries, the blend of the painted regions — is computed once on a copy at
// 1/kWorldLayerCoarsening of the resolution; slope, normals, wear, deposit and
// the material weights are computed tile by tile from the full heights and
// that copy. Every value depends on its position only, never on the tile it
// is computed in: tiles agree bit for bit whatever the tiling, and a river
// keeps its drainage area across every tile border. LibTorch-free.
#include <opencv2/core.hpp>

#include "reefgen/terrain/layers.hpp"

namespace reefgen::terrain {

// The coarse copy's cell is this many of the world's a side. Its routing
// takes ≈ 30 bytes a cell: 2 GB at 8193² for a 16385² world, where the
// whole field's would take 8 GB beside 15 layer maps of 1 GB each.
constexpr int kWorldLayerCoarsening = 2;

// What a world's tiles read besides its heights.
struct WorldLayerField {
  cv::Size size;            // the world's, samples
  double metres_per_px = 0; // the world's
  cv::Mat1f before_m;       // uneroded heights over the same ground, any resolution (empty: no wear or deposit)
  cv::Mat1f flow_area_m2;   // coarse grid: drainage area (sea 0)
  cv::Mat1f settled_m;      // coarse grid: the worn material settled by the flow (settle_sediment)
  cv::Mat1f abyss, reef, beach;  // coarse grid: the painted regions' blended shares
};

// height_m: the finished world (sea level 0, row 0 north); before_m: its
// uneroded heights and region: its region ids (or empty: regions_of_heights),
// each at any resolution over the same ground (read by position).
WorldLayerField world_layer_field(const cv::Mat1f& height_m, const cv::Mat1f& before_m, const cv::Mat1b& region,
                                  double metres_per_px, const LayerParams& p = {}, int threads = 1);

// The layers of `tile`, a rectangle of height_m (the whole world's heights):
// the same values, pixel for pixel, as any other tiling gives. A field of
// another size over the same ground (a resampled copy) is read by position.
Layers world_layers_tile(const cv::Mat1f& height_m, const WorldLayerField& f, const cv::Rect& tile,
                         const LayerParams& p = {}, int threads = 1);

// The scales of a world's tiled layer files: the coarse field's largest
// drainage area (no tile's is larger), the whole world's largest wear and
// deposit (read in bands of rows; the deposit by p's settle_deg, as the tiles').
LayerScales world_layer_scales(const cv::Mat1f& height_m, const WorldLayerField& f, const LayerParams& p = {});

}  // namespace reefgen::terrain
