#include "reefgen/engines/bundle.hpp"
#include "reefgen/engines/unity_importer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/io.hpp"
#include "stages.hpp"

namespace reefgen::engines {

namespace fs = std::filesystem;

namespace detail {

void stage_text(StagedOutputs& staged, const fs::path& path, const std::string& text) {
  staged.write(path, [&](const fs::path& t) { write_text_atomic(t, text); });
}

cv::Mat3f resample_corners3(const cv::Mat3f& f, int side) {
  std::vector<cv::Mat1f> ch;
  cv::split(f, ch);
  for (auto& c : ch) c = resample_corners(c, side);
  cv::Mat3f out;
  cv::merge(ch, out);
  return out;
}

UnrealPlacement unreal_placement(int side, double mpp, const HeightRange& r) {
  const double scale_xy = mpp * 100.0;
  return {scale_xy, (r.hi_m - r.lo_m) * 100.0 / 512.0, (r.lo_m + r.hi_m) / 2 * 100.0, (side - 1) / 2.0 * scale_xy};
}

std::string UnrealPlacement::readme_line() const {
  return "Location X " + format_num("%.1f", -half_cm) + ", Y " + format_num("%.1f", -half_cm) + ", Z " + format_num("%.1f", location_z_cm) +
         " (sea level at Z = 0); Scale X " + format_num("%.4f", scale_xy_cm) + ", Y " + format_num("%.4f", scale_xy_cm) + ", Z " +
         format_num("%.4f", scale_z) + ".\n";
}

terrain::Layers weights_at(const terrain::Layers& L, int side) {
  terrain::Layers w;
  for (int m = 0; m < terrain::kNumMaterials; ++m) w.weight[size_t(m)] = resample_corners(L.weight[size_t(m)], side);
  return w;
}

}  // namespace detail

namespace {

// Samples per Unity tile edge, 2¹² + 1: Unity's largest heightmap.
constexpr int kUnityTileCells = kUnityMaxSide - 1;

// The eight weights resampled to side² samples, quantised to sum 255
// (terrain::splat_maps), packed four per RGBA image.
std::array<cv::Mat4b, 2> splats_at(const terrain::Layers& L, int side) { return terrain::splat_maps(detail::weights_at(L, side)); }

// One channel of a splat pair: material m's 8-bit weight.
cv::Mat1b weight_layer(const std::array<cv::Mat4b, 2>& splat, int m) {
  cv::Mat1b out;
  cv::extractChannel(splat[size_t(m / 4)], out, m % 4);
  return out;
}

using detail::stage_text;

}  // namespace

namespace detail {

nlohmann::json stage_unity_tiles(StagedOutputs& staged, const fs::path& dir, const std::string& name,
                                 const cv::Mat1f& h, int resampled_from, double mpp, int max_tile_side,
                                 const UnitySplats& splat_of, const std::string& kind) {
  const int side = h.cols, tiles = side <= max_tile_side ? 1 : (side - 1) / (max_tile_side - 1);
  const HeightRange r = export_range(h);
  const int tile_side = tiles == 1 ? side : max_tile_side, alpha = tile_side - 1;
  nlohmann::json files = nlohmann::json::array();
  // Tile (X, Z): X east, Z north, 0 at the south-west; neighbours share
  // their edge samples, so the edges are equal by construction.
  for (int tz = 0; tz < tiles; ++tz)
    for (int tx = 0; tx < tiles; ++tx) {
      const std::string stem = tiles == 1 ? name : name + "_" + std::to_string(tx) + "_" + std::to_string(tz);
      const int row0 = (tiles - 1 - tz) * (tile_side - 1), col0 = tx * (tile_side - 1);
      const cv::Rect rect(col0, row0, tile_side, tile_side);
      staged.write(dir / (stem + ".raw"), [&](const fs::path& p) {
        const std::vector<uint8_t> raw = unity_raw_bytes(h(rect), r);
        write_file_atomic(p, raw.data(), raw.size());
      });
      const fs::path splat_files[2] = {dir / (stem + ".splat0.png"), dir / (stem + ".splat1.png")};
      // A resumed run has them already: the tile's layers are not made again.
      std::array<cv::Mat4b, 2> splat;
      if (!staged.resumed(splat_files[0]) || !staged.resumed(splat_files[1])) splat = splat_of(rect, alpha);
      for (int s = 0; s < 2; ++s) {
        // The splat maps are RGBA (materials 4s … 4s+3); the PNG writer takes
        // OpenCV's BGRA: swapped, red and blue would trade materials. Converted
        // in the writer, which a resumed file never runs: its map was not made
        // (converting the empty map stopped every resume of a world whose
        // Unity bundle had been staged).
        const cv::Mat4b rgba = splat[size_t(s)];
        staged.write(splat_files[s], [rgba](const fs::path& p) {
          cv::Mat4b cut;
          cv::cvtColor(rgba, cut, cv::COLOR_RGBA2BGRA);
          write_png(p, cut);
        });
      }
      files.push_back({{"raw", stem + ".raw"}, {"splat", {stem + ".splat0.png", stem + ".splat1.png"}}, {"x", tx}, {"z", tz}});
    }
  const double width_m = mpp * (tile_side - 1), height_m = r.hi_m - r.lo_m;
  // Tiles placed so that the whole terrain's centre is the world's origin.
  const double half_m = 0.5 * width_m * tiles;
  for (auto& f : files)
    f["position_m"] = {width_m * f["x"].get<int>() - half_m, r.lo_m, width_m * f["z"].get<int>() - half_m};
  std::string readme =
      "reefgen " + kind + " for Unity (Terrain), " + std::to_string(tiles * tiles) + " tile(s)\n\n"
      "In one click: put ReefgenImporter.cs anywhere under your project's Assets/ (it is editor-only), then\n"
      "Tools > reefgen > Import Unity bundle... and pick this folder. Every tile becomes a Terrain with its\n"
      "heights, size, position, 8 Terrain Layers and their weights, neighbours connected (assets saved in\n"
      "Assets/reefgen/" + name + "/). By hand, as follows.\n\n"
      "Heights: " + std::to_string(tile_side) + "x" + std::to_string(tile_side) +
      " samples per tile, 16-bit little-endian RAW, southern row first (no flip needed).\n"
      "Range: " + format_num("%.1f", r.lo_m) + " m ... " + format_num("%.1f", r.hi_m) + " m -> 0 ... 65535 (linear).\n" +
      (side != resampled_from ? "Resampled from " + std::to_string(resampled_from) + " to " + std::to_string(side) +
                       " samples a side (Unity takes 2^n+1 up to 4097; larger terrains are tiled).\n"
                 : std::string()) +
      "\nFor each tile NAME_X_Z.raw (X east, Z north; one file when there is no suffix):\n"
      "1. Create a Terrain; Terrain Settings > Texture Resolutions: Heightmap Resolution " + std::to_string(tile_side) +
      ", Control Texture Resolution " + std::to_string(alpha) + ".\n"
      "2. Import Raw...: Depth Bit 16, Width " + std::to_string(tile_side) + ", Height " + std::to_string(tile_side) +
      ", Byte Order Windows, Flip Vertically OFF, Terrain Size X " + format_num("%.3f", width_m) + ", Y " +
      format_num("%.3f", height_m) + ", Z " + format_num("%.3f", width_m) + ".\n"
      "3. Position: X = " + format_num("%.3f", width_m) + " * X_index - " + format_num("%.3f", half_m) + ", Y " + format_num("%.3f", r.lo_m) +
      " (sea level at world Y = 0), Z = " + format_num("%.3f", width_m) + " * Z_index - " + format_num("%.3f", half_m) +
      "\n   (the " + kind + "'s centre at the world's origin, as the Unreal and Godot bundles place it).\n"
      "4. Materials: add 8 Terrain Layers (Paint Texture > Edit Terrain Layers) in this order. Their weights are\n"
      "   NAME.splat0.png (layers 1-4 in R,G,B,A) and NAME.splat1.png (layers 5-8), top row = north, summing to 255\n"
      "   at every pixel. Unity's editor has no command that loads a splat map: ReefgenImporter.cs (above) reads the\n"
      "   two PNGs and calls TerrainData.SetAlphamaps; from your own editor script do the same (weights / 255, rows\n"
      "   flipped: the alphamap's row 0 is south).\n"
      "   Layers: ";
  for (int m = 0; m < terrain::kNumMaterials; ++m) readme += std::string(m ? ", " : "") + terrain::material_name(m);
  readme += "\n";
  stage_text(staged, dir / "README.txt", readme);
  nlohmann::json layers = nlohmann::json::array(), colours = nlohmann::json::array();
  for (int m = 0; m < terrain::kNumMaterials; ++m) {
    layers.push_back(terrain::material_name(m));
    for (int k = 0; k < 3; ++k) colours.push_back(terrain::material_rgb(m)[k] / 255.0);
  }
  nlohmann::json j = {{"engine", "unity"}, {"name", name}, {"tiles", files}, {"tiles_per_axis", tiles},
                      {"tile_side_px", tile_side}, {"alphamap_px", alpha}, {"side_px", side},
                      {"range_m", {r.lo_m, r.hi_m}}, {"terrain_size_m", {width_m, height_m, width_m}},
                      {"position_y_m", r.lo_m}, {"row_order", "south first"}, {"layers", layers},
                      {"layer_colours", colours}};
  if (side != resampled_from) j["resampled_from_px"] = resampled_from;  // only when resampled
  // What the importer reads (ReefgenImporter.cs, carried beside it).
  stage_text(staged, dir / "reefgen-unity.json", j.dump(2) + "\n");
  stage_text(staged, dir / "ReefgenImporter.cs", kUnityImporterCs);
  return j;
}


}  // namespace detail

namespace {

nlohmann::json stage_unity(StagedOutputs& staged, const fs::path& dir, const std::string& name, const BundleInput& in) {
  const int n = in.height_m.cols, tiles = unity_tiles(n);
  const int side = tiles == 1 ? unity_side(n) : tiles * kUnityTileCells + 1;
  const cv::Mat1f h = side == n ? in.height_m : resample_corners(in.height_m, side);
  const double mpp = in.metres_per_px * (n - 1) / (side - 1);
  const int alpha = (tiles == 1 ? side : kUnityMaxSide) - 1;
  // The island's weights resampled once to the whole alphamap, then cut.
  const auto splat = splats_at(*in.layers, tiles * alpha);
  return detail::stage_unity_tiles(staged, dir, name, h, n, mpp, kUnityMaxSide, [&](const cv::Rect& rect, int a) {
    const cv::Rect cut(rect.x / (rect.width - 1) * a, rect.y / (rect.height - 1) * a, a, a);
    return std::array<cv::Mat4b, 2>{splat[0](cut).clone(), splat[1](cut).clone()};
  });
}

nlohmann::json stage_unreal(StagedOutputs& staged, const fs::path& dir, const std::string& name, const BundleInput& in) {
  const int n = in.height_m.cols, side = unreal_side(n);
  const cv::Mat1f h = side == n ? in.height_m : resample_corners(in.height_m, side);
  const double mpp = in.metres_per_px * (n - 1) / (side - 1);
  const HeightRange r = export_range(h);
  staged.write(dir / (name + ".png"), [h, r](const fs::path& p) { write_png16(p, h, r.lo_m, r.hi_m); });
  const auto splat = splats_at(*in.layers, side);
  nlohmann::json layers = nlohmann::json::object();
  for (int m = 0; m < terrain::kNumMaterials; ++m) {
    const cv::Mat1b w = weight_layer(splat, m);
    const std::string file = name + "_" + terrain::material_name(m) + ".png";
    staged.write(dir / file, [w](const fs::path& p) { write_png(p, w); });
    layers[terrain::material_name(m)] = file;
  }
  const detail::UnrealPlacement at = detail::unreal_placement(side, mpp, r);
  std::string readme =
      "reefgen island for Unreal Engine (Landscape)\n\n"
      "Heights: " + name + ".png, " + std::to_string(side) + "x" + std::to_string(side) +
      " 16-bit greyscale, row 0 = north (-Y side of the Landscape).\n"
      "Range: " + format_num("%.1f", r.lo_m) + " m ... " + format_num("%.1f", r.hi_m) + " m -> 0 ... 65535 (linear).\n" +
      (side != n ? "Resampled from " + std::to_string(n) + " to " + std::to_string(side) +
                       " samples a side, the nearest Landscape size (505, 1009, 2017, 4033, 8129).\n"
                 : std::string()) +
      "\n1. Landscape mode > Manage > New > Import from File: Heightmap File " + name + ".png.\n"
      "2. " + at.readme_line() +
      "3. Layers: create a Landscape material with these weight-blended layers and, for each, Import the file:\n";
  for (int m = 0; m < terrain::kNumMaterials; ++m)
    readme += std::string("   ") + terrain::material_name(m) + ": " + name + "_" + terrain::material_name(m) + ".png\n";
  readme += "   (8-bit greyscale, same size as the heights; the eight sum to 255 at every pixel)\n";
  stage_text(staged, dir / "README.txt", readme);
  nlohmann::json j = {{"engine", "unreal"}, {"heightmap", name + ".png"}, {"weight_layers", layers}, {"side_px", side},
                      {"range_m", {r.lo_m, r.hi_m}}, {"scale_cm", at.scale_json()}, {"location_cm", at.location_json()}};
  if (side != n) j["resampled_from_px"] = n;  // only when resampled
  return j;
}

nlohmann::json stage_gis(StagedOutputs& staged, const fs::path& dir, const std::string& name, const BundleInput& in,
                         int threads) {
  nlohmann::json j = gis::stage_geotiff_files(staged, (dir / name).string(), in.height_m, in.layers, in.metres_per_px,
                                              in.geo, threads);
  const std::string crs = in.geo.crs.empty() ? "none: a local metric grid centred on (0, 0) unless --origin" : in.geo.crs;
  std::string readme =
      "reefgen island for GIS (GDAL, QGIS)\n\n"
      "Heights: " + name + ".height.tif, float32 metres (sea level 0), pixel size " + format_num("%.6f", in.metres_per_px) +
      " m.\nCRS: " + crs + ".\n"
      "Layers: the float layers as GeoTIFFs beside it (slope in degrees, flow in m^2, wear and deposit in m).\n\n"
      "  gdalinfo -stats " + name + ".height.tif\n"
      "  gdaldem hillshade " + name + ".height.tif hillshade.tif\n"
      "  gdal_contour -fl 0 " + name + ".height.tif coast.gpkg      # the coastline\n"
      "QGIS: Layer > Add Layer > Add Raster Layer; with no CRS, assign your project's metric CRS.\n";
  stage_text(staged, dir / "README.txt", readme);
  j["engine"] = "gis";
  return j;
}

}  // namespace

std::string engine_names() {
  std::string out;
  for (const Engine e : kEngines) out += std::string(out.empty() ? "" : ", ") + to_string(e);
  return out;
}

bool is_engine_name(const std::string& s) {
  return std::any_of(std::begin(kEngines), std::end(kEngines), [&](Engine e) { return s == to_string(e); });
}

Engine engine_from_string(const std::string& s) {
  for (const Engine e : kEngines)
    if (s == to_string(e)) return e;
  std::string names = engine_names();
  names.replace(names.rfind(", "), 2, " or ");
  throw Error("--for " + s + ": use " + names + " (docs/ENGINES.md)");
}

const char* to_string(Engine e) {
  switch (e) {
    case Engine::Unity: return "unity";
    case Engine::Unreal: return "unreal";
    case Engine::Godot: return "godot";
    case Engine::Blender: return "blender";
    case Engine::Gis: return "gis";
  }
  return "?";
}

int unity_side(int side) {
  int best = kUnityMinSide;
  for (int s = kUnityMinSide; s <= kUnityMaxSide; s = 2 * s - 1)
    if (std::abs(s - side) <= std::abs(best - side)) best = s;
  return best;
}

int unity_tiles(int side) { return side <= kUnityMaxSide ? 1 : (side - 1 + kUnityTileCells - 1) / kUnityTileCells; }

int unreal_side(int side) {
  int best = kUnrealSides[0];
  for (const int s : kUnrealSides)
    if (std::abs(s - side) <= std::abs(best - side)) best = s;
  return best;
}

cv::Mat1f resample_corners(const cv::Mat1f& f, int side) {
  if (f.rows < 2 || f.cols < 2 || side < 2) throw Error("resample: fields and sides must be at least 2 samples");
  cv::Mat1f out(side, side);
  const double sy = double(f.rows - 1) / (side - 1), sx = double(f.cols - 1) / (side - 1);
  for (int r = 0; r < side; ++r) {
    const double y = r * sy;
    const int y0 = std::min(int(y), f.rows - 2);
    const float fy = float(y - y0);
    const float* a = f.ptr<float>(y0);
    const float* b = f.ptr<float>(y0 + 1);
    float* o = out.ptr<float>(r);
    for (int c = 0; c < side; ++c) {
      const double x = c * sx;
      const int x0 = std::min(int(x), f.cols - 2);
      const float fx = float(x - x0);
      const float top = a[x0] + fx * (a[x0 + 1] - a[x0]), bot = b[x0] + fx * (b[x0 + 1] - b[x0]);
      o[c] = top + fy * (bot - top);
    }
  }
  return out;
}

std::vector<uint8_t> unity_raw_bytes(const cv::Mat1f& h, const HeightRange& r) {
  const cv::Mat1w code = to_u16(h, r.lo_m, r.hi_m);
  std::vector<uint8_t> out(size_t(h.total()) * 2);
  size_t k = 0;
  for (int row = h.rows - 1; row >= 0; --row)
    for (int c = 0; c < h.cols; ++c) {
      out[k++] = uint8_t(code(row, c) & 0xFF);
      out[k++] = uint8_t(code(row, c) >> 8);
    }
  return out;
}

nlohmann::json stage_bundle(StagedOutputs& staged, const fs::path& dir, const std::string& name, Engine e,
                            const BundleInput& in, int threads) {
  if (in.height_m.rows != in.height_m.cols) throw Error("bundle: the height field must be square");
  if (e != Engine::Gis && !in.layers) throw Error("internal: the " + std::string(to_string(e)) + " bundle needs the layers");
  ensure_writable_dir(dir);
  nlohmann::json j = e == Engine::Unity     ? stage_unity(staged, dir, name, in)
                     : e == Engine::Unreal  ? stage_unreal(staged, dir, name, in)
                     : e == Engine::Godot   ? detail::stage_godot(staged, dir, name, in, threads)
                     : e == Engine::Blender ? detail::stage_blender(staged, dir, name, in, threads)
                                            : stage_gis(staged, dir, name, in, threads);
  j["folder"] = dir.filename().string();
  j["readme"] = "README.txt";
  return j;
}

nlohmann::json stage_bundles(StagedOutputs& staged, const fs::path& prefix, const std::vector<Engine>& engines,
                             const BundleInput& in, int threads) {
  nlohmann::json out = nlohmann::json::object();
  const std::string name = prefix.filename().string();
  for (const Engine e : engines)
    out[to_string(e)] = stage_bundle(staged, fs::path(prefix.string() + "." + to_string(e)), name, e, in, threads);
  return out;
}

std::string size_note(Engine e, int side, const std::string& fix) {
  const std::string n = std::to_string(side) + "²";
  auto avoid = [&](int want) {
    const std::string w = std::to_string(want);
    return fix.empty() ? "resample the input to " + w + "² first (e.g. gdalwarp -ts " + w + " " + w + ") to avoid it"
                       : "use " + fix + " " + w + " to avoid it";
  };
  if (e == Engine::Unity) {
    if (unity_tiles(side) > 1) {
      const int tiles = unity_tiles(side), tiled = tiles * (kUnityMaxSide - 1) + 1;
      const std::string grid = std::to_string(tiles) + "×" + std::to_string(tiles) + " tiles of 4097²";
      if (tiled == side) return "--for unity: " + n + " is past Unity's 4097²: written as " + grid + " (no resampling)";
      return "--for unity: " + n + " is past Unity's 4097²: resampled to " + std::to_string(tiled) + "² in " + grid;
    }
    if (unity_side(side) != side)
      return "--for unity: " + n + " resampled to " + std::to_string(unity_side(side)) +
             "² (Unity takes 2^n+1: 33, 65, …, 4097; " + avoid(unity_side(side)) + ")";
  }
  if (e == Engine::Unreal && unreal_side(side) != side)
    return "--for unreal: " + n + " resampled to " + std::to_string(unreal_side(side)) +
           "² (Landscape sizes 505, 1009, 2017, 4033, 8129; " + avoid(unreal_side(side)) + ")";
  return "";
}

std::vector<Engine> engines_from_strings(const std::vector<std::string>& names) {
  std::vector<Engine> out;
  for (const std::string& list : names)
    for (size_t at = 0; at <= list.size();) {
      const size_t comma = std::min(list.find(',', at), list.size());
      const Engine e = engine_from_string(list.substr(at, comma - at));
      if (std::find(out.begin(), out.end(), e) == out.end()) out.push_back(e);
      at = comma + 1;
    }
  return out;
}

PlannedOutputs planned_outputs(const std::filesystem::path& prefix, const std::vector<Engine>& bundles) {
  PlannedOutputs p;
  const std::string pre = prefix.string();
  for (const char* ext : {".height.exr", ".height.png", ".r16", ".preview.png", ".json", ".obj", ".glb", terrain::kRainFileSuffix})
    p.files.push_back(pre + ext);
  for (const auto& ext : terrain::layer_file_suffixes()) p.files.push_back(pre + ext);
  for (const auto& ext : gis::geotiff_suffixes()) p.files.push_back(pre + ext);
  for (const Engine e : bundles) p.folders.push_back(pre + "." + to_string(e));
  return p;
}

void refuse_outputs_over_inputs(const std::vector<std::filesystem::path>& inputs, const PlannedOutputs& planned) {
  refuse_output_over_input(inputs, planned.files, planned.folders);
}

}  // namespace reefgen::engines
