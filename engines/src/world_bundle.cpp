#include "reefgen/engines/world_bundle.hpp"

#include <algorithm>

#include "reefgen/error.hpp"
#include "reefgen/io.hpp"
#include "stages.hpp"

namespace reefgen::engines {

namespace fs = std::filesystem;
using detail::stage_text;

namespace {

std::string tile_stem(const std::string& name, int i, int j) {
  return name + "_x" + std::to_string(i) + "_y" + std::to_string(j);
}

// True when a resumed run has every band file of tile `stem` already.
bool resumed_bands(const StagedOutputs& staged, const fs::path& dir, const std::string& stem,
                   const std::vector<gis::TiledBand>& bands) {
  return std::all_of(bands.begin(), bands.end(),
                     [&](const gis::TiledBand& b) { return staged.resumed(dir / (stem + b.suffix + ".tif")); });
}

const terrain::WorldLayerField& need_field(const WorldInput& in, Engine e) {
  if (!in.field) throw Error("internal: the " + std::string(to_string(e)) + " world bundle needs the layers");
  return *in.field;
}

nlohmann::json stage_unity_world(StagedOutputs& staged, const fs::path& dir, const std::string& name,
                                 const WorldInput& in, int threads) {
  const terrain::WorldLayerField& f = need_field(in, Engine::Unity);
  const int n = in.height_m.cols, cells = in.tiling.unity_tile_side - 1;
  const int tiles = std::max(1, (n - 1 + cells - 1) / cells), side = tiles * cells + 1;
  const cv::Mat1f h = side == n ? in.height_m : resample_corners(in.height_m, side);
  const double mpp = in.metres_per_px * (n - 1) / (side - 1);
  return detail::stage_unity_tiles(staged, dir, name, h, n, mpp, in.tiling.unity_tile_side, [&](const cv::Rect& rect, int alpha) {
    const terrain::Layers L = terrain::world_layers_tile(h, f, rect, in.rules, threads);
    return terrain::splat_maps(detail::weights_at(L, alpha));
  }, "world");
}

nlohmann::json stage_unreal_world(StagedOutputs& staged, const fs::path& dir, const std::string& name,
                                  const WorldInput& in, int threads) {
  const terrain::WorldLayerField& f = need_field(in, Engine::Unreal);
  const WorldTiling& t = in.tiling;
  const int n = in.height_m.cols, per_axis = t.unreal_tiles_per_axis, tile_px = t.unreal_tile_px;
  const int side = per_axis * tile_px, quads = t.unreal_section_quads;
  if ((side - 1) % quads != 0) throw Error("internal: the Unreal world's side is not whole sections");
  const cv::Mat1f h = side == n ? in.height_m : resample_corners(in.height_m, side);
  const double mpp = in.metres_per_px * (n - 1) / (side - 1);
  const HeightRange r = export_range(h);
  nlohmann::json tiles = nlohmann::json::array();
  for (int j = 0; j < per_axis; ++j)
    for (int i = 0; i < per_axis; ++i) {
      const cv::Rect rect(i * tile_px, j * tile_px, tile_px, tile_px);
      const std::string stem = tile_stem(name, i, j);
      nlohmann::json layer_files = nlohmann::json::object();
      for (int m = 0; m < terrain::kNumMaterials; ++m)
        layer_files[terrain::material_name(m)] =
            name + "_" + terrain::material_name(m) + "_x" + std::to_string(i) + "_y" + std::to_string(j) + ".png";
      // A resumed run has made this tile's weight layers already.
      bool made = true;
      for (const auto& [m, file] : layer_files.items()) made = made && staged.resumed(dir / file.get<std::string>());
      std::array<cv::Mat4b, 2> splat;
      if (!made) splat = terrain::splat_maps(terrain::world_layers_tile(h, f, rect, in.rules, threads));
      std::vector<StagedOutputs::Job> jobs;
      const cv::Mat1f ht = h(rect);
      jobs.emplace_back(dir / (stem + ".png"), [ht, r](const fs::path& p) { write_png16(p, ht, r.lo_m, r.hi_m); });
      for (int m = 0; m < terrain::kNumMaterials; ++m) {
        cv::Mat1b w;
        if (!made) cv::extractChannel(splat[size_t(m / 4)], w, m % 4);
        jobs.emplace_back(dir / layer_files[terrain::material_name(m)].get<std::string>(),
                          [w](const fs::path& p) { write_png(p, w); });
      }
      staged.write_all(jobs, threads);
      tiles.push_back({{"x", i}, {"y", j}, {"heightmap", stem + ".png"}, {"weight_layers", layer_files}});
    }
  const detail::UnrealPlacement at = detail::unreal_placement(side, mpp, r);
  const int components = (side - 1) / quads;
  std::string readme =
      "reefgen world for Unreal Engine 5 (Landscape, World Partition), " + std::to_string(per_axis * per_axis) +
      " tiles\n\n"
      "Heights: " + name + "_x<i>_y<j>.png, " + std::to_string(per_axis) + " x " + std::to_string(per_axis) + " tiles of " +
      std::to_string(tile_px) + "x" + std::to_string(tile_px) +
      " 16-bit greyscale, no overlap: one Landscape of " + std::to_string(side) + "x" + std::to_string(side) +
      " samples.\nTile x<i> is the i-th from the west, y<j> the j-th from the north (row 0 = north, the -Y side).\n"
      "Range: " + format_num("%.1f", r.lo_m) + " m ... " + format_num("%.1f", r.hi_m) + " m -> 0 ... 65535 (linear), the same in every tile.\n" +
      (side != n ? "Resampled from " + std::to_string(n) + " to " + std::to_string(side) + " samples a side (corner to corner).\n"
                 : std::string()) +
      "\n1. A World Partition level; Landscape mode > Manage > New > Import from File: Heightmap File " + name +
      "_x0_y0.png\n   (the importer finds every _x<i>_y<j> tile and places tile (i, j) at (" +
      std::to_string(tile_px) + " i, " + std::to_string(tile_px) + " j)).\n"
      "2. Section Size " + std::to_string(quads) + "x" + std::to_string(quads) +
      " Quads, Sections Per Component 1x1, Number of Components " + std::to_string(components) + " x " +
      std::to_string(components) + " (" + std::to_string(side - 1) + " = " + std::to_string(quads) +
      " x " + std::to_string(components) + " quads: no resampling in Unreal).\n"
      "3. " + at.readme_line() +
      "4. Layers: a Landscape material with these weight-blended layers; for each, pick its _x0_y0 tile:\n";
  for (int m = 0; m < terrain::kNumMaterials; ++m)
    readme += std::string("   ") + terrain::material_name(m) + ": " + name + "_" + terrain::material_name(m) + "_x0_y0.png\n";
  readme += "   (8-bit greyscale, tiled as the heights; the eight sum to 255 at every pixel)\n";
  stage_text(staged, dir / "README.txt", readme);
  nlohmann::json j = {{"engine", "unreal"}, {"tiles", tiles}, {"tiles_per_axis", per_axis}, {"tile_px", tile_px},
                      {"side_px", side}, {"section_quads", quads},
                      {"components_per_axis", components}, {"range_m", {r.lo_m, r.hi_m}},
                      {"scale_cm", at.scale_json()}, {"location_cm", at.location_json()}};
  if (side != n) j["resampled_from_px"] = n;  // only when the bundle's side is not the world's
  return j;
}

nlohmann::json stage_godot_world(StagedOutputs& staged, const fs::path& dir, const std::string& name,
                                 const WorldInput& in, int threads) {
  const terrain::WorldLayerField& f = need_field(in, Engine::Godot);
  const WorldTiling& t = in.tiling;
  return detail::stage_godot_world(staged, dir, name, in.height_m, in.metres_per_px,
                                   {t.godot_region_px, t.godot_tile_px, t.godot_tiles_per_axis},
                                   [&](const cv::Mat1f& h, const cv::Rect& rect) {
                                     return terrain::world_layers_tile(h, f, rect, in.rules, threads);
                                   });
}

nlohmann::json stage_gis_world(StagedOutputs& staged, const fs::path& dir, const std::string& name,
                               const WorldInput& in, int threads) {
  std::vector<gis::TiledBand> bands = {gis::height_band()};
  if (in.field) bands.insert(bands.end(), gis::layer_bands().begin(), gis::layer_bands().end());
  const cv::Mat1f& h = in.height_m;
  nlohmann::json j = gis::stage_geotiff_band_tiles(
      staged, dir, name, h.size(), in.metres_per_px, in.geo, bands,
      [&](const cv::Rect& r, int i, int j) {
        std::vector<cv::Mat1f> out = {h(r)};
        if (!in.field) return out;
        if (resumed_bands(staged, dir, tile_stem(name, i, j), gis::layer_bands())) {
          out.resize(bands.size());  // written by an earlier run: nothing to make
          return out;
        }
        const auto more = gis::layer_band_pixels(terrain::world_layers_tile(h, *in.field, r, in.rules, threads));
        out.insert(out.end(), more.begin(), more.end());
        return out;
      },
      threads, in.tiling.gis_tile_max_px);
  const std::string readme =
      "reefgen world for GIS: " + std::to_string(h.cols) + "x" + std::to_string(h.rows) + " float32 heights in metres, " +
      format_num("%.6f", in.metres_per_px) + " m a pixel, in GeoTIFF tiles NAME_xI_yJ.height.tif (I east, J south, no overlap)\n"
      "and one mosaic " + name + ".height.vrt that GDAL and QGIS open as the whole world" +
      (in.field ? "; the float layers (flow in m^2, slope in degrees, wear and deposit in m) tiled the same way,\n"
                  "each with its own mosaic NAME.<layer>.vrt"
                : "") +
      ":\n  gdalinfo " + name + ".height.vrt\n  gdaldem hillshade " + name + ".height.vrt hillshade.tif\n";
  stage_text(staged, dir / "README.txt", readme);
  j["engine"] = "gis";
  return j;
}

}  // namespace

std::string world_size_note(Engine e, int side, const WorldTiling& t) {
  if (e == Engine::Godot) {
    const int godot_side = t.godot_tiles_per_axis * t.godot_tile_px;
    if (side == godot_side) return "";
    return "--for godot: " + std::to_string(side) + "² resampled to " + std::to_string(godot_side) + "² in " +
           std::to_string(t.godot_tiles_per_axis) + "×" + std::to_string(t.godot_tiles_per_axis) +
           " Terrain3D tiles of " + std::to_string(t.godot_tile_px) + "² (regions of " + std::to_string(t.godot_region_px) +
           "; use --size " + std::to_string(godot_side) + " to avoid it)";
  }
  const int unreal_side = t.unreal_tiles_per_axis * t.unreal_tile_px;
  if (e != Engine::Unreal) return size_note(e, side);
  if (side == unreal_side) return "";
  return "--for unreal: " + std::to_string(side) + "² resampled to " + std::to_string(unreal_side) + "² in " +
         std::to_string(t.unreal_tiles_per_axis) + "×" + std::to_string(t.unreal_tiles_per_axis) +
         " World Partition tiles of " + std::to_string(t.unreal_tile_px) + "² (use --size " +
         std::to_string(unreal_side) + " to avoid it)";
}

bool has_world_bundle(Engine e) { return e != Engine::Blender; }

nlohmann::json stage_world_layers(StagedOutputs& staged, const fs::path& dir, const std::string& name,
                                  const WorldInput& in, bool geotiff, int threads) {
  if (!in.field) throw Error("internal: the world's layers need their field");
  const cv::Mat1f& h = in.height_m;
  const terrain::LayerScales scales = terrain::world_layer_scales(h, *in.field, in.rules);
  nlohmann::json files = nlohmann::json::array();
  // Each tile's layer files are staged as the tile is made; its float layers
  // go to the GeoTIFF tiles (none without --geotiff).
  const std::vector<gis::TiledBand> bands = geotiff ? gis::layer_bands() : std::vector<gis::TiledBand>{};
  nlohmann::json j = gis::stage_geotiff_band_tiles(
      staged, dir, name, h.size(), in.metres_per_px, in.geo, bands,
      [&](const cv::Rect& r, int i, int j) {
        const std::string stem = tile_stem(name, i, j);
        const std::vector<std::string> suffixes = terrain::layer_file_suffixes();
        const bool made = resumed_bands(staged, dir, stem, bands) &&
                          std::all_of(suffixes.begin(), suffixes.end(),
                                      [&](const std::string& x) { return staged.resumed(dir / (stem + x)); });
        // A resumed tile: its files are registered, not made again.
        const terrain::Layers L = made ? terrain::Layers{} : terrain::world_layers_tile(h, *in.field, r, in.rules, threads);
        if (made)
          for (const auto& x : suffixes) staged.write(dir / (stem + x), [](const fs::path&) {});
        else
          terrain::stage_layer_files(staged, (dir / stem).string(), L, in.metres_per_px, in.rules, threads, &scales);
        files.push_back({{"x", i}, {"y", j}, {"files", terrain::layer_file_names((dir / stem).string())}});
        return geotiff ? (made ? std::vector<cv::Mat1f>(bands.size()) : gis::layer_band_pixels(L)) : std::vector<cv::Mat1f>{};
      },
      threads, in.tiling.gis_tile_max_px);
  nlohmann::json encoding = terrain::layer_files_description(in.metres_per_px, in.rules, scales);
  const std::string readme =
      "reefgen world layers: " + std::to_string(h.cols) + "x" + std::to_string(h.rows) + " samples in " +
      std::to_string(files.size()) + " tiles NAME_x<i>_y<j>.<layer>.png (i east, j south, no overlap; tile size in the\n"
      "sidecar). Every tile has flow, slope, wear, deposit, normal, splat0 + splat1 (8 material weights summing to 255)\n"
      "and materials; the encodings and their scales are the whole world's, the same in every tile (docs/LAYERS.md)." +
      (geotiff ? std::string("\nThe float layers are also GeoTIFF tiles, each layer with a VRT mosaic NAME.<layer>.vrt.") : "") +
      "\n";
  stage_text(staged, dir / "README.txt", readme);
  j["layer_tiles"] = files;
  j["layers"] = encoding;
  j["scales"] = {{"flow_area_m2", scales.flow_area_m2}, {"wear_m", scales.wear_m}, {"deposit_m", scales.deposit_m}};
  j["coarse_px"] = {in.field->flow_area_m2.cols, in.field->flow_area_m2.rows};
  if (!geotiff) {
    j.erase("tiles");
    j.erase("mosaics");
  }
  return j;
}

nlohmann::json stage_world_bundle(StagedOutputs& staged, const fs::path& dir, const std::string& name, Engine e,
                                  const WorldInput& in, int threads) {
  if (!has_world_bundle(e))
    throw Error("--for " + std::string(to_string(e)) + ": a world past one file per layer has no " + to_string(e) +
                " bundle (use unity, unreal, godot or gis, or a world of at most 8192²)");
  if (e != Engine::Gis && in.height_m.rows != in.height_m.cols) throw Error("bundle: the height field must be square");
  ensure_writable_dir(dir);
  nlohmann::json j = e == Engine::Unity    ? stage_unity_world(staged, dir, name, in, threads)
                     : e == Engine::Unreal ? stage_unreal_world(staged, dir, name, in, threads)
                     : e == Engine::Godot  ? stage_godot_world(staged, dir, name, in, threads)
                                           : stage_gis_world(staged, dir, name, in, threads);
  j["folder"] = dir.filename().string();
  j["readme"] = "README.txt";
  return j;
}

}  // namespace reefgen::engines
