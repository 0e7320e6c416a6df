// The Godot bundle: Terrain3D's height, control and colour maps
// (docs/ENGINES.md "Godot (Terrain3D)").
#include <cmath>
#include <cstdlib>
#include <cstring>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/io.hpp"
#include "stages.hpp"

namespace reefgen::engines {

namespace fs = std::filesystem;

namespace {

constexpr uint32_t kIdMask = 0x1F, kBlendMask = 0xFF;
constexpr int kBaseShift = 27, kOverlayShift = 22, kBlendShift = 14;
// Terrain3D's colour map: RGB multiplies the textures, alpha 0.5 leaves
// their roughness as it is (its own default fill, white at alpha 0.5).
constexpr uint8_t kNeutralRoughness = 128;

// The control bits as the float32 pixels Terrain3D reads (Image::FORMAT_RF
// holding the uint32 memory as is).
cv::Mat1f bits_as_floats(const cv::Mat1i& bits) {
  cv::Mat1f out(bits.size());
  std::memcpy(out.ptr<float>(), bits.ptr<int>(), bits.total() * sizeof(float));
  return out;
}

// `f` grown to `side` samples a side, the original centred (offset `pad`),
// the new border filled by `fill` (OpenCV border mode, or a constant).
template <class M>
M pad_to(const M& f, int side, int pad, int border, const cv::Scalar& value = {}) {
  M out;
  cv::copyMakeBorder(f, out, pad, side - f.rows - pad, pad, side - f.cols - pad, border, value);
  return out;
}

// Step 3's Import Position lines for both importers (x, z); a note when the
// 1.0 importer's clamp cannot reach the position.
std::string terrain3d_position_lines(const Terrain3DPlacement& x, const Terrain3DPlacement& z) {
  std::string s = "   Import Position: Terrain3D 1.0.x (released; it reads metres) (" + std::to_string(x.position_1_0_m) +
                  ", " + std::to_string(z.position_1_0_m) + ");\n"
                  "   Terrain3D main after 2fdda09 (unreleased; samples x Vertex Spacing) (" +
                  std::to_string(x.position_main_px) + ", " + std::to_string(z.position_main_px) + "),\n";
  if (!x.within_clamp || !z.within_clamp)
    s += "   NOTE: 1.0.x's importer clamps the position to +/-8192 m: this one lies beyond it (use a smaller canvas, or\n"
         "   import at the clamp and move the regions with its Region Mover),\n";
  return s;
}

}  // namespace

int terrain3d_region_side(int side) {
  for (const int r : kTerrain3DRegionSides)
    if (side <= r * kTerrain3DMaxRegions) return r;
  throw Error("Terrain3D holds at most " + std::to_string(kTerrain3DRegionSides[3] * kTerrain3DMaxRegions) +
              " samples a side; this island has " + std::to_string(side));
}

Terrain3DPlacement terrain3d_placement(int centre_px, int region_px, double spacing_m, int corner_px) {
  if (region_px <= 0 || !(spacing_m > 0)) throw Error("terrain3d: region and vertex spacing must be > 0");
  if (corner_px == kTerrain3DAutoCorner)
    corner_px = int(std::lround(-double(centre_px) / region_px)) * region_px;
  if (corner_px % region_px != 0) throw Error("terrain3d: a map's corner must lie on the region grid");
  Terrain3DPlacement p;
  p.corner_px = corner_px;
  // The middle of the corner's region: floored to that region whatever the
  // rounding to whole metres (a position exactly on the corner, read back
  // as samples in float, could floor to the region before it).
  p.position_1_0_m = std::lround((corner_px + region_px / 2.0) * spacing_m);
  p.position_main_px = corner_px + region_px / 2;
  p.centre_m = (corner_px + centre_px) * spacing_m;
  p.within_clamp = std::labs(p.position_1_0_m) <= kTerrain3DImportClamp;
  return p;
}

uint32_t terrain3d_encode(const Terrain3DControl& c) {
  return (uint32_t(c.base) & kIdMask) << kBaseShift | (uint32_t(c.overlay) & kIdMask) << kOverlayShift |
         (uint32_t(c.blend) & kBlendMask) << kBlendShift;
}

Terrain3DControl terrain3d_decode(uint32_t x) {
  return {int(x >> kBaseShift & kIdMask), int(x >> kOverlayShift & kIdMask), int(x >> kBlendShift & kBlendMask)};
}

cv::Mat1i terrain3d_control(const terrain::Layers& L) {
  const int H = L.weight[0].rows, W = L.weight[0].cols;
  cv::Mat1i out(H, W);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      // The two heaviest materials, the lower id first on ties.
      int a = 0, b = -1;
      for (int m = 1; m < terrain::kNumMaterials; ++m) {
        const float w = L.weight[size_t(m)](y, x);
        if (w > L.weight[size_t(a)](y, x)) b = a, a = m;
        else if (b < 0 || w > L.weight[size_t(b)](y, x)) b = m;
      }
      const float wa = L.weight[size_t(a)](y, x), wb = L.weight[size_t(b)](y, x);
      Terrain3DControl c{a, a, 0};
      if (wb > 0) c = {a, b, int(std::lround(255.0 * wb / (wa + wb)))};
      uint32_t bits = terrain3d_encode(c);
      std::memcpy(&out(y, x), &bits, sizeof bits);
    }
  return out;
}

namespace detail {

nlohmann::json stage_godot(StagedOutputs& staged, const fs::path& dir, const std::string& name, const BundleInput& in,
                           int threads) {
  const int n = in.height_m.cols, region = terrain3d_region_side(n);
  const int side = (n + region - 1) / region * region, pad = (side - n) / 2;
  const cv::Mat1f h = pad_to(in.height_m, side, pad, cv::BORDER_REPLICATE);
  // The padding is deep sea floor (base = overlay = material 0, blend 0: all bits 0).
  const cv::Mat1f control = pad_to(bits_as_floats(terrain3d_control(*in.layers)), side, pad, cv::BORDER_CONSTANT);
  cv::Mat4b colour;
  cv::cvtColor(pad_to(terrain::material_colour_map(*in.layers, false), side, pad, cv::BORDER_REPLICATE), colour,
               cv::COLOR_BGR2BGRA);
  colour.forEach([](cv::Vec4b& p, const int*) { p[3] = kNeutralRoughness; });
  staged.write_all({{dir / (name + ".height.exr"), [&](const fs::path& p) { write_exr_channel(p, h, "R", {}, kExrZipLevel); }},
                    {dir / (name + ".control.exr"), [&](const fs::path& p) { write_exr_channel(p, control, "R", {}, kExrZipLevel); }},
                    {dir / (name + ".color.png"), [&](const fs::path& p) { write_png(p, colour); }}},
                   threads);
  double lo = 0, hi = 0;
  cv::minMaxLoc(in.height_m, &lo, &hi);
  // The island's centre sample, pad + (n − 1)/2 in, as near (0, 0) as the
  // region grid allows.
  const Terrain3DPlacement at = terrain3d_placement(pad + (n - 1) / 2, region, in.metres_per_px);
  std::string readme =
      "reefgen island for Godot 4 with Terrain3D (1.0.0, 1.0.1, 1.0.2; and main after 2fdda09, step 3)\n\n"
      "Maps: " + std::to_string(side) + "x" + std::to_string(side) + " samples (the island's " + std::to_string(n) +
      " centred: " + std::to_string(pad) + " samples of its edge added on the north and west,\n"
      "the rest on the south and east) so the maps fill whole regions of " + std::to_string(region) + ".\n"
      "  " + name + ".height.exr   float32 metres, sea level 0 (" + format_num("%.1f", lo) + " ... " + format_num("%.1f", hi) + " m)\n"
      "  " + name + ".control.exr  Terrain3D's control map: uint32 bits in a float32 EXR (base texture, overlay, blend)\n"
      "  " + name + ".color.png    colour map: RGB tints the textures, alpha 0.5 (roughness unchanged)\n\n"
      "1. Terrain3D node: Region Size " + std::to_string(region) + ", Vertex Spacing " + format_num("%.4f", in.metres_per_px) +
      " (metres between samples).\n"
      "2. Texture list: add 8 textures, ids in this order:\n";
  for (int m = 0; m < terrain::kNumMaterials; ++m)
    readme += "   " + std::to_string(m) + " " + terrain::material_name(m) + "\n";
  readme +=
      "3. Open addons/terrain_3d/tools/importer.tscn, select Importer: Height File " + name +
      ".height.exr, Control File " + name + ".control.exr, Color File " + name +
      ".color.png,\n" + terrain3d_position_lines(at, at) +
      "   Import Scale 1, Height Offset 0 (heights are metres).\n"
      "   Terrain3D places the maps' top-left sample on the region corner (" + std::to_string(at.corner_px) + ", " +
      std::to_string(at.corner_px) + ") samples: the island's\n"
      "   centre lands at (" + format_num("%.2f", at.centre_m) + ", " + format_num("%.2f", at.centre_m) +
      ") m (regions snap positions; 0, 0 exactly only when the padding allows).\n"
      "4. Run Import, then save the Terrain3D data.\n";
  stage_text(staged, dir / "README.txt", readme);
  return {{"engine", "godot"},      {"heightmap", name + ".height.exr"}, {"control_map", name + ".control.exr"},
          {"color_map", name + ".color.png"}, {"side_px", side},        {"padding_px", pad},
          {"resampled_from_px", n}, {"region_side_px", region},          {"vertex_spacing_m", in.metres_per_px},
          {"import_position_m_terrain3d_1_0", {at.position_1_0_m, at.position_1_0_m}},
          {"import_position_px_terrain3d_main", {at.position_main_px, at.position_main_px}},
          {"corner_px", {at.corner_px, at.corner_px}}, {"island_centre_m", {at.centre_m, 0.0, at.centre_m}},
          {"control_bits", "base id << 27 | overlay id << 22 | blend << 14"}, {"texture_ids", [] {
             nlohmann::json ids = nlohmann::json::array();
             for (int m = 0; m < terrain::kNumMaterials; ++m) ids.push_back(terrain::material_name(m));
             return ids;
           }()}};
}

nlohmann::json stage_godot_world(StagedOutputs& staged, const fs::path& dir, const std::string& name,
                                 const cv::Mat1f& height_m, double metres_per_px, const GodotWorldLayout& layout,
                                 const TileLayers& layers_of) {
  const int n = height_m.cols, tile = layout.tile_px, per_axis = layout.tiles_per_axis, side = tile * per_axis;
  const cv::Mat1f h = side == n ? height_m : resample_corners(height_m, side);
  const double mpp = metres_per_px * (n - 1) / (side - 1);
  nlohmann::json tiles = nlohmann::json::array();
  std::string positions;
  const int world_corner = terrain3d_placement(side / 2, layout.region_px, mpp).corner_px;
  bool all_within = true;
  for (int j = 0; j < per_axis; ++j)
    for (int i = 0; i < per_axis; ++i) {
      const cv::Rect rect(i * tile, j * tile, tile, tile);
      const std::string stem = name + "_x" + std::to_string(i) + "_y" + std::to_string(j);
      const fs::path files[3] = {dir / (stem + ".height.exr"), dir / (stem + ".control.exr"), dir / (stem + ".color.png")};
      // A resumed run has made this tile's maps already.
      const bool made = staged.resumed(files[0]) && staged.resumed(files[1]) && staged.resumed(files[2]);
      cv::Mat1f control;
      cv::Mat4b colour;
      if (!made) {
        const terrain::Layers L = layers_of(h, rect);
        control = bits_as_floats(terrain3d_control(L));
        cv::cvtColor(terrain::material_colour_map(L, false), colour, cv::COLOR_BGR2BGRA);
        colour.forEach([](cv::Vec4b& p, const int*) { p[3] = kNeutralRoughness; });
      }
      const cv::Mat1f ht = h(rect).clone();  // the EXR writer takes whole rows
      staged.write_all({{files[0], [ht](const fs::path& p) { write_exr_channel(p, ht, "R", {}, kExrZipLevel); }},
                        {files[1], [control](const fs::path& p) { write_exr_channel(p, control, "R", {}, kExrZipLevel); }},
                        {files[2], [colour](const fs::path& p) { write_png(p, colour); }}},
                       3);
      // Each tile on its region corner, the world's corner the region corner
      // nearest −side/2 (the world centred as near 0, 0 as the grid allows).
      const int tile_centre = tile / 2;
      const Terrain3DPlacement ax = terrain3d_placement(tile_centre, layout.region_px, mpp, world_corner + i * tile);
      const Terrain3DPlacement az = terrain3d_placement(tile_centre, layout.region_px, mpp, world_corner + j * tile);
      all_within &= ax.within_clamp && az.within_clamp;
      tiles.push_back({{"x", i}, {"y", j}, {"heightmap", stem + ".height.exr"}, {"control_map", stem + ".control.exr"},
                       {"color_map", stem + ".color.png"},
                       {"import_position_m_terrain3d_1_0", {ax.position_1_0_m, az.position_1_0_m}},
                       {"import_position_px_terrain3d_main", {ax.position_main_px, az.position_main_px}},
                       {"corner_px", {ax.corner_px, az.corner_px}}, {"centre_m", {ax.centre_m, 0.0, az.centre_m}}});
      positions += "   " + stem + ": 1.0.x (" + std::to_string(ax.position_1_0_m) + ", " + std::to_string(az.position_1_0_m) +
                   "), main (" + std::to_string(ax.position_main_px) + ", " + std::to_string(az.position_main_px) + ")\n";
    }
  double lo = 0, hi = 0;
  cv::minMaxLoc(h, &lo, &hi);
  std::string readme =
      "reefgen world for Godot 4 with Terrain3D (1.0.0, 1.0.1, 1.0.2; and main after 2fdda09, step 3), " +
      std::to_string(per_axis * per_axis) + " tiles\n\n"
      "Maps: " + std::to_string(per_axis) + " x " + std::to_string(per_axis) + " tiles NAME_x<i>_y<j> of " +
      std::to_string(tile) + "x" + std::to_string(tile) + " samples (" + std::to_string(tile / layout.region_px) + " x " +
      std::to_string(tile / layout.region_px) + " regions of " + std::to_string(layout.region_px) + " each), x<i> from the west, y<j> from the north;\n"
      "one world of " + std::to_string(side) + "x" + std::to_string(side) + " samples" +
      (side != n ? " (resampled corner to corner from " + std::to_string(n) + ")" : std::string()) + ".\n"
      "  .height.exr   float32 metres, sea level 0 (" + format_num("%.1f", lo) + " ... " + format_num("%.1f", hi) + " m)\n"
      "  .control.exr  Terrain3D's control map: uint32 bits in a float32 EXR (base texture, overlay, blend)\n"
      "  .color.png    colour map: RGB tints the textures, alpha 0.5 (roughness unchanged)\n\n"
      "1. Terrain3D node: Region Size " + std::to_string(layout.region_px) + ", Vertex Spacing " + format_num("%.4f", mpp) +
      " (metres between samples).\n"
      "2. Texture list: add 8 textures, ids in this order:\n";
  for (int m = 0; m < terrain::kNumMaterials; ++m) readme += "   " + std::to_string(m) + " " + terrain::material_name(m) + "\n";
  readme +=
      "3. For each tile, in addons/terrain_3d/tools/importer.tscn select Importer: its Height, Control and Color files,\n"
      "   Import Scale 1, Height Offset 0, and this Import Position: Terrain3D 1.0.x (released) reads it in metres,\n"
      "   main after 2fdda09 (unreleased) in samples x Vertex Spacing; either way Terrain3D puts the tile's top-left\n"
      "   sample on a region corner, so tiles that share a border meet there (the world's top-left at sample " +
      std::to_string(world_corner) + "),\n"
      "   then Run Import:\n" + positions +
      (all_within ? std::string()
                  : std::string("   NOTE: 1.0.x's importer clamps positions to +/-8192 m and some lie beyond it: import those\n"
                                "   at the clamp and move their regions with its Region Mover, or use Terrain3D main.\n")) +
      "4. Save the Terrain3D data.\n";
  stage_text(staged, dir / "README.txt", readme);
  return {{"engine", "godot"}, {"tiles", tiles}, {"tiles_per_axis", per_axis}, {"tile_px", tile},
          {"region_side_px", layout.region_px}, {"side_px", side}, {"resampled_from_px", n},
          {"vertex_spacing_m", mpp}, {"control_bits", "base id << 27 | overlay id << 22 | blend << 14"}};
}

}  // namespace detail

}  // namespace reefgen::engines
