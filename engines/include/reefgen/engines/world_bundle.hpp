#pragma once
// A world too large for one file per layer (docs/WORLDS.md "Tiles"): its
// layers and engine bundles in tiles, each tile's layers made from the
// world's field (terrain/world_layers.hpp) as the tile is written, so memory
// holds one tile's layers at a time and tiles agree at their borders.
//   layers  PREFIX.layers/NAME_x{i}_y{j}.<layer>.png (+ float .tif and one
//           VRT mosaic per layer with --geotiff), the GeoTIFF tile grid
//   unity   NAME_X_Z tiles of 4097 samples whose shared edges are equal,
//           splat maps per tile
//   unreal  World Partition's tiled import: NAME_x{i}_y{j}.png tiles of
//           4096² making one 16384² Landscape, weight layers
//           NAME_<material>_x{i}_y{j}.png
//   godot   Terrain3D maps NAME_x{i}_y{j}.{height.exr,control.exr,color.png}
//           in 4 × 4 tiles of 4 × 4 regions of 1024, each imported at its top-left corner
//   gis     NAME_x{i}_y{j}.height.tif (+ the float layers) and VRT mosaics
// Blender takes worlds up to one file (a mesh of 268 M vertices is no asset).
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reefgen/engines/bundle.hpp"
#include "reefgen/terrain/world_layers.hpp"

namespace reefgen::engines {

// The tile layouts of a world's bundles (the defaults are the engines';
// tests use small ones).
struct WorldTiling {
  // Unity: NAME_X_Z tiles of this many samples a side (2ⁿ + 1), neighbours
  // sharing their edge samples.
  int unity_tile_side = kUnityMaxSide;
  // Unreal: per_axis² tiles of tile_px² samples, no overlap (the importer
  // places tile (i, j) at (tile_px i, tile_px j)): one Landscape of
  // per_axis · tile_px samples a side, 16384 = 16383 quads + 1 = 129
  // components of one 127-quad section, so Unreal does not resample it.
  int unreal_tile_px = 4096, unreal_tiles_per_axis = 4, unreal_section_quads = 127;
  // Terrain3D: per_axis² tiles of tile_px² samples, each region_px regions a
  // side, imported one by one at their top-left corners: 16384² is 16 × 16 regions of
  // 1024, within Terrain3D's 32 × 32.
  int godot_region_px = 1024, godot_tile_px = 4096, godot_tiles_per_axis = 4;
  // GeoTIFF and layer tiles: at most this many pixels a side.
  int gis_tile_max_px = gis::kGeoTiffTileMaxPx;
};

// True for the engines whose bundle a world gets in tiles (all but blender).
bool has_world_bundle(Engine e);

struct WorldInput {
  const cv::Mat1f& height_m;                  // the world, metres, row 0 north
  const terrain::WorldLayerField* field;      // its layers' field; null = no layers (the gis bundle's heights only)
  double metres_per_px;
  gis::GeoReference geo;
  terrain::LayerParams rules;
  WorldTiling tiling = {};
};

// One line saying how `e`'s world bundle changes a world of `side` samples
// (Unity's tiles, Unreal's 16384² Landscape), or "" when it takes it as it is.
std::string world_size_note(Engine e, int side, const WorldTiling& t = {});

// PREFIX.layers/: the layer files of every tile of the GeoTIFF grid, with
// the whole world's scales; with geotiff, the float layers as GeoTIFF tiles
// and VRT mosaics beside them. Returns what the sidecar says.
nlohmann::json stage_world_layers(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name,
                                  const WorldInput& in, bool geotiff, int threads = 1);

// The bundle of `e` for a world, in `dir`; unity and unreal need in.field.
// Throws reefgen::Error for an engine without a world bundle.
nlohmann::json stage_world_bundle(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name,
                                  Engine e, const WorldInput& in, int threads = 1);

}  // namespace reefgen::engines
