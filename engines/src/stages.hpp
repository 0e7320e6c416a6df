#pragma once
// Pieces the bundle writers share (engines/src only).
#include <array>
#include <filesystem>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reefgen/engines/bundle.hpp"
#include "reefgen/text.hpp"

namespace reefgen::engines::detail {

// The bundles' EXRs: zlib level 1, 0.2 % larger than level 6 on a 2049²
// island and written several times faster (the bundle's cost bar,
// docs/BENCHMARKS.md).
constexpr int kExrZipLevel = 1;

void stage_text(StagedOutputs& staged, const std::filesystem::path& path, const std::string& text);
// resample_corners of each channel.
cv::Mat3f resample_corners3(const cv::Mat3f& field, int side);
// The eight weights resampled to side² samples, corner-aligned.
terrain::Layers weights_at(const terrain::Layers& layers, int side);

// threads: files written side by side, rows shared out (same bytes whatever the count).
nlohmann::json stage_godot(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name,
                           const BundleInput& in, int threads);
nlohmann::json stage_blender(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name,
                             const BundleInput& in, int threads);

// Where an Unreal Landscape of side² samples, mpp apart, with heights `r`
// goes: Unreal maps the 16 bits to 512 m at Z scale 100 %, centred on code
// 32768; X and Y in cm, the Landscape centred on (0, 0), sea level at Z = 0.
struct UnrealPlacement {
  double scale_xy_cm, scale_z, location_z_cm, half_cm;
  // "Location X …, Y …, Z … (sea level at Z = 0); Scale X …, Y …, Z …." for the README.
  std::string readme_line() const;
  nlohmann::json scale_json() const { return {scale_xy_cm, scale_xy_cm, scale_z}; }
  nlohmann::json location_json() const { return {-half_cm, -half_cm, location_z_cm}; }
};
UnrealPlacement unreal_placement(int side, double metres_per_px, const HeightRange& r);

// A Unity tile's two splat maps (RGBA8, alphamap_px a side) for the heights'
// rectangle `rect` (its samples, corner to corner).
using UnitySplats = std::function<std::array<cv::Mat4b, 2>(const cv::Rect& rect, int alphamap_px)>;
// Unity's bundle of heights `h` already at Unity's sides (2ⁿ + 1 up to
// tile_side, or tiles · (tile_side − 1) + 1: NAME_X_Z tiles whose shared
// edges are equal), each tile's splat maps from splat_of, made as the tile
// is written. `kind` heads the README ("island", "world").
nlohmann::json stage_unity_tiles(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name,
                                 const cv::Mat1f& h, int resampled_from, double metres_per_px, int tile_side,
                                 const UnitySplats& splat_of, const std::string& kind = "island");

// Terrain3D's maps of a world in tiles of whole regions, each imported at its
// own position (stage_godot_world).
struct GodotWorldLayout {
  int region_px, tile_px, tiles_per_axis;
};
// The layers of `rect` of heights `h` (a world's tile, made as it is written).
using TileLayers = std::function<terrain::Layers(const cv::Mat1f& h, const cv::Rect& rect)>;
nlohmann::json stage_godot_world(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name,
                                 const cv::Mat1f& height_m, double metres_per_px, const GodotWorldLayout& layout,
                                 const TileLayers& layers_of);

}  // namespace reefgen::engines::detail
