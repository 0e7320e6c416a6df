#pragma once
// Engine bundles (docs/ENGINES.md): one island's heights and material
// layers in a tool's own layout, in a folder with a README.txt giving that
// island's import steps and numbers. LibTorch-free.
//   unity   NAME.raw (16-bit LE, 2ⁿ+1, south row first), NAME.splat0/1.png
//           (RGBA8, 4 materials each, alphamap 2ⁿ); beyond 4097, tiles
//           NAME_X_Z whose shared edges are equal
//   unreal  NAME.png (16-bit, a Landscape size 505…8129) and one 8-bit
//           greyscale weight layer NAME_<material>.png per material
//   godot   Terrain3D: NAME.height.exr (metres), NAME.control.exr (its uint32
//           control bits in a float EXR), NAME.color.png, region-aligned
//   blender NAME.glb (mesh + baked colour and normal textures), NAME.height.exr
//           and NAME.displace.py (the displacement recipe as a script)
//   gis     NAME.height.tif (+ the float layers) with a local metric grid or
//           the given CRS (gis/geotiff.hpp)
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reefgen/gis/geotiff.hpp"
#include "reefgen/heightfile.hpp"
#include "reefgen/terrain/layers.hpp"

namespace reefgen {
class StagedOutputs;
}

namespace reefgen::engines {

enum class Engine { Unity, Unreal, Godot, Blender, Gis };
// Every engine, in the order the docs and messages list them.
constexpr Engine kEngines[] = {Engine::Unity, Engine::Unreal, Engine::Godot, Engine::Blender, Engine::Gis};
// "unity, unreal, godot, blender, gis": for help texts and messages.
std::string engine_names();
// True for "unity", "unreal", "godot", "blender" or "gis".
bool is_engine_name(const std::string& name);
// The engine of that name; anything else throws reefgen::Error listing them.
Engine engine_from_string(const std::string& name);
const char* to_string(Engine e);

// Unity's heightmap resolutions: 2ⁿ + 1 from 33 to 4097 samples a side.
constexpr int kUnityMinSide = 33, kUnityMaxSide = 4097;
// Unreal's recommended Landscape sizes (one component layout each).
constexpr int kUnrealSides[] = {505, 1009, 2017, 4033, 8129};

// Terrain3D's region sizes (vertices a side) and how many regions its map
// holds per axis (32 × 32 in Terrain3D 1.0).
constexpr int kTerrain3DRegionSides[] = {256, 512, 1024, 2048};
constexpr int kTerrain3DMaxRegions = 32;
// The smallest region size whose 32 regions span `side` samples.
int terrain3d_region_side(int side);

// Where Terrain3D's importer puts a map, per axis (docs/ENGINES.md
// "Terrain3D versions"). Every release slices the map into regions and
// floors each slice's position to the region grid (Terrain3DData::
// import_images, get_region_location), so a map's top-left sample lands on a
// region corner. The importer's Import Position is read in metres by the
// released 1.0.0, 1.0.1 and 1.0.2 (importer.gd: Vector3(import_position.x,
// 0, import_position.y)) and in samples × vertex spacing by main after
// 2fdda09 (unreleased); both are whole numbers, clamped to ±8192.
struct Terrain3DPlacement {
  int corner_px;         // the map's top-left sample lands at this sample of the world (a multiple of the region)
  long position_1_0_m;   // Import Position for Terrain3D 1.0.x (metres, inside the corner's region)
  int position_main_px;  // Import Position for Terrain3D main after 2fdda09 (samples)
  double centre_m;       // where sample `centre_px` of the map lands, metres
  bool within_clamp;     // |position_1_0_m| ≤ 8192 (the importer clamps beyond it)
};
// A map whose sample `centre_px` should land nearest 0, placed on regions
// of `region_px` samples at `spacing_m` metres; `corner_px` given
// (kTerrain3DAutoCorner: the region corner nearest −centre_px).
inline constexpr int kTerrain3DAutoCorner = INT32_MIN;
Terrain3DPlacement terrain3d_placement(int centre_px, int region_px, double spacing_m, int corner_px = kTerrain3DAutoCorner);
// Whole numbers Terrain3D's importer takes for its Import Position.
inline constexpr long kTerrain3DImportClamp = 8192;

// One control-map pixel in Terrain3D's documented uint32 bit layout
// (docs/ENGINES.md): base texture id in bits 31–27, overlay id 26–22, blend
// (overlay's share, 0 = base only) 21–14; the UV angle/scale, hole,
// navigation and autoshader bits are 0 (manual texturing).
struct Terrain3DControl {
  int base = 0, overlay = 0, blend = 0;  // ids 0..31, blend 0..255
};
uint32_t terrain3d_encode(const Terrain3DControl& c);
Terrain3DControl terrain3d_decode(uint32_t bits);
// Per pixel: base = the heaviest material, overlay = the second, blend =
// round(255·w₂/(w₁ + w₂)); texture ids are the material numbers 0..7 (so
// no pixel's bits make a NaN or an infinity as a float).
cv::Mat1i terrain3d_control(const terrain::Layers& layers);

// The 2ⁿ + 1 side Unity takes for a field of `side` samples: the nearest
// (ties up), at least 33; sides past 4097 are tiled (unity_tiles).
int unity_side(int side);
// Tiles per axis for Unity: 1 up to 4097 samples, else ⌈(side − 1)/4096⌉.
int unity_tiles(int side);
// The Landscape size nearest to `side` (ties up).
int unreal_side(int side);

// Resampled so that corner samples stay on the corners: sample i of the
// output sits at i·(n − 1)/(side − 1) of the input (the span (n − 1)·px is
// kept; a side of n samples is n − 1 cells). Bilinear.
cv::Mat1f resample_corners(const cv::Mat1f& field, int side);

// Unity's RAW: little-endian uint16, the southern row first (Unity's terrain
// row 0 is at z = 0, the south edge), v = round(65535·(h − lo)/(hi − lo)).
std::vector<uint8_t> unity_raw_bytes(const cv::Mat1f& height_m, const HeightRange& range);

struct BundleInput {
  cv::Mat1f height_m;             // metres, sea level 0, row 0 north
  const terrain::Layers* layers;  // required for unity and unreal (the material weights)
  double metres_per_px;           // sample spacing
  gis::GeoReference geo;          // gis only
};

// Stages the bundle of `e` in folder `dir` (created; nothing else is in
// place before staged.commit()), files named NAME.*, and returns what the
// sidecar says about it (files, sizes, resampling, import numbers).
nlohmann::json stage_bundle(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name, Engine e,
                            const BundleInput& in, int threads = 1);

// Every bundle asked for, each in the folder PREFIX.<engine>/ with files
// named after PREFIX's file name; returns {engine: what stage_bundle said}.
nlohmann::json stage_bundles(StagedOutputs& staged, const std::filesystem::path& prefix,
                             const std::vector<Engine>& engines, const BundleInput& in, int threads = 1);

// One line saying how `e` changes a field of `side` samples a side (Unity's
// 2ⁿ + 1 or its tiles, Unreal's nearest Landscape size, Terrain3D's region
// padding), or "" when the engine takes it as it is.
// `fix`: how the user picks another size, e.g. "--size" (the note then says
// "use --size N to avoid it"); empty for a command that takes its input's
// size (erode): the note says to resample the input to N² first.
std::string size_note(Engine e, int side, const std::string& fix = "--size");

// Every path a command with output prefix PREFIX may write: the height
// files, sidecar, meshes, layer files and GeoTIFFs, and the folders of the
// bundles asked for. The one list the "never overwrite an input" check uses
// (refuse_output_over_input); a command adds what it alone writes.
struct PlannedOutputs {
  std::vector<std::filesystem::path> files, folders;
};
PlannedOutputs planned_outputs(const std::filesystem::path& prefix, const std::vector<Engine>& bundles);
// Throws Error when one of `inputs` is a planned file or lies in a planned folder.
void refuse_outputs_over_inputs(const std::vector<std::filesystem::path>& inputs, const PlannedOutputs& planned);

// "unity,unreal" or repeated flags → engines, in order, each once.
std::vector<Engine> engines_from_strings(const std::vector<std::string>& names);

}  // namespace reefgen::engines
