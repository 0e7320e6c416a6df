// Engine bundles (docs/ENGINES.md) at the byte level: Unity's RAW order and
// sizes, tiles whose shared edges are equal, Unreal's Landscape sizes and
// weight layers, the splat weights summing to 255, Terrain3D's control bits
// and regions, the Blender GLB's tangent-space normals.
#include <gtest/gtest.h>

#include <regex>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/engines/bundle.hpp"
#include "reefgen/engines/world_bundle.hpp"
#include "reefgen/error.hpp"
#include "reefgen/io.hpp"
#include "reefgen/mesh.hpp"
#include "test_util.hpp"

using namespace reefgen;
using namespace reefgen::engines;
namespace fs = std::filesystem;

namespace {

// Weights of the eight materials: smooth, different per material, summing
// to 1 (what compute_layers guarantees).
terrain::Layers weights(int side) {
  terrain::Layers L;
  cv::Mat1f sum(side, side, 0.f);
  for (int m = 0; m < terrain::kNumMaterials; ++m) {
    cv::Mat1f w(side, side);
    for (int r = 0; r < side; ++r)
      for (int c = 0; c < side; ++c) w(r, c) = 1.f + std::sin(0.1f * (m + 1) * r + 0.07f * c * (m % 3));
    L.weight[size_t(m)] = w;
    sum += w;
  }
  for (auto& w : L.weight) w /= sum;
  return L;
}

std::vector<uint8_t> bytes_of(const fs::path& p) {
  const std::string s = read_text(p, size_t(1) << 30);
  return {s.begin(), s.end()};
}

void expect_splats_sum_to_255(const fs::path& s0, const fs::path& s1, int side) {
  const cv::Mat a = cv::imread(s0.string(), cv::IMREAD_UNCHANGED), b = cv::imread(s1.string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(a.type(), CV_8UC4);
  ASSERT_EQ(a.cols, side);
  ASSERT_EQ(b.size(), a.size());
  for (int r = 0; r < a.rows; ++r)
    for (int c = 0; c < a.cols; ++c) {
      int s = 0;
      for (int k = 0; k < 4; ++k) s += a.at<cv::Vec4b>(r, c)[k] + b.at<cv::Vec4b>(r, c)[k];
      ASSERT_EQ(s, 255) << s0 << " at " << r << "," << c;
    }
}

}  // namespace

TEST(Engines, SizesEachEngineTakes) {
  EXPECT_EQ(unity_side(1025), 1025);
  EXPECT_EQ(unity_side(1000), 1025);
  EXPECT_EQ(unity_side(600), 513);
  EXPECT_EQ(unity_side(12), 33);
  EXPECT_EQ(unity_side(4097), 4097);
  EXPECT_EQ(unity_tiles(4097), 1);
  EXPECT_EQ(unity_tiles(4098), 2);
  EXPECT_EQ(unity_tiles(8193), 2);
  EXPECT_EQ(unreal_side(1025), 1009);
  EXPECT_EQ(unreal_side(2049), 2017);
  EXPECT_EQ(unreal_side(8192), 8129);
  EXPECT_EQ(unreal_side(100), 505);
  EXPECT_EQ(size_note(Engine::Unity, 1025), "");
  EXPECT_NE(size_note(Engine::Unity, 1024).find("resampled to 1025²"), std::string::npos);
  EXPECT_NE(size_note(Engine::Unity, 8193).find("2×2 tiles"), std::string::npos);
  EXPECT_EQ(size_note(Engine::Unreal, 2017), "");
  EXPECT_NE(size_note(Engine::Unreal, 2049).find("resampled to 2017²"), std::string::npos);
  EXPECT_EQ(size_note(Engine::Gis, 777), "");
  EXPECT_EQ(engine_from_string("godot"), Engine::Godot);
  EXPECT_EQ(engine_from_string("blender"), Engine::Blender);
  EXPECT_THROW(engine_from_string("cryengine"), Error);
  EXPECT_EQ(engines_from_strings({"unity,gis", "unity"}), (std::vector<Engine>{Engine::Unity, Engine::Gis}));
}

// Corner samples stay on the corners and a plane is resampled exactly.
TEST(Engines, ResamplingKeepsCornersAndPlanes) {
  cv::Mat1f f(65, 65);
  for (int r = 0; r < 65; ++r)
    for (int c = 0; c < 65; ++c) f(r, c) = 3.f * r - 2.f * c;
  const cv::Mat1f g = resample_corners(f, 33);
  for (int r = 0; r < 33; ++r)
    for (int c = 0; c < 33; ++c) ASSERT_NEAR(g(r, c), 3.f * 2 * r - 2.f * 2 * c, 1e-4);
  const cv::Mat1f up = resample_corners(f, 129);
  EXPECT_FLOAT_EQ(up(0, 0), f(0, 0));
  EXPECT_FLOAT_EQ(up(128, 128), f(64, 64));
  EXPECT_FLOAT_EQ(up(0, 128), f(0, 64));
}

// Unity's row 0 is the south edge: the RAW starts with the image's last row,
// little-endian, v = round(65535·(h − lo)/(hi − lo)).
TEST(Engines, UnityRawIsSouthFirstLittleEndian) {
  cv::Mat1f h(33, 33);
  for (int r = 0; r < 33; ++r)
    for (int c = 0; c < 33; ++c) h(r, c) = float(r * 33 + c);  // 0 at the north-west corner
  const std::vector<uint8_t> raw = unity_raw_bytes(h, {0, 1088});
  ASSERT_EQ(raw.size(), 33u * 33u * 2u);
  auto at = [&](size_t k) { return int(raw[2 * k]) | int(raw[2 * k + 1]) << 8; };
  EXPECT_EQ(at(0), int(std::lround(65535.0 * (32 * 33) / 1088)));  // south-west corner first
  EXPECT_EQ(at(32), int(std::lround(65535.0 * (32 * 33 + 32) / 1088)));
  EXPECT_EQ(at(33 * 32), 0);  // the north-west corner is the last row's first sample
  EXPECT_EQ(at(33 * 33 - 1), int(std::lround(65535.0 * 32 / 1088)));
}

// Past 4097 samples Unity gets NAME_X_Z tiles of 4097 (X east, Z north)
// whose shared edge rows and columns are the same samples, and splat tiles
// of 4096² summing to 255.
TEST(Engines, UnityTilesShareTheirEdges) {
  const int n = 4200;
  cv::Mat1f h(n, n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) h(r, c) = 50.f * std::sin(r * 0.003f) + 0.01f * c;
  const terrain::Layers L = weights(64);
  const fs::path dir = test::temp_dir("unity-tiles");
  StagedOutputs staged;
  const nlohmann::json j = stage_bundles(staged, dir / "isle", {Engine::Unity}, {h, &L, 2.0, {}});
  staged.commit();
  const fs::path b = dir / "isle.unity";
  ASSERT_EQ(j["unity"]["tiles_per_axis"], 2);
  const int t = kUnityMaxSide;
  std::vector<std::vector<uint8_t>> tile(4);
  for (int z = 0; z < 2; ++z)
    for (int x = 0; x < 2; ++x) {
      tile[size_t(2 * z + x)] = bytes_of(b / ("isle_" + std::to_string(x) + "_" + std::to_string(z) + ".raw"));
      ASSERT_EQ(tile[size_t(2 * z + x)].size(), size_t(t) * t * 2);
    }
  auto sample = [&](int k, int row, int col) {  // row 0 = south in the RAW
    const auto& v = tile[size_t(k)];
    const size_t i = 2 * (size_t(row) * t + col);
    return int(v[i]) | int(v[i + 1]) << 8;
  };
  for (int i = 0; i < t; ++i) {
    ASSERT_EQ(sample(0, i, t - 1), sample(1, i, 0)) << "X edge, south row of tiles, row " << i;
    ASSERT_EQ(sample(2, i, t - 1), sample(3, i, 0)) << "X edge, north row of tiles, row " << i;
    ASSERT_EQ(sample(0, t - 1, i), sample(2, 0, i)) << "Z edge, west tiles, column " << i;
  }
  expect_splats_sum_to_255(b / "isle_1_1.splat0.png", b / "isle_1_1.splat1.png", t - 1);
  // Placed from the README's own numbers, the terrain's centre is the
  // world's origin (as Unreal's and Godot's bundles place the island), and
  // the sidecar's per-tile positions say the same.
  const std::string readme = read_text(b / "README.txt");
  const size_t at = readme.find("Position: X = ");
  ASSERT_NE(at, std::string::npos) << readme;
  double w = 0, half = 0, size_x = 0;
  ASSERT_EQ(std::sscanf(readme.c_str() + at, "Position: X = %lf * X_index - %lf", &w, &half), 2) << readme;
  ASSERT_EQ(std::sscanf(readme.c_str() + readme.find("Terrain Size X "), "Terrain Size X %lf", &size_x), 1);
  EXPECT_NEAR(w, size_x, 1e-3) << "a tile's step is its size";
  const double west = w * 0 - half, east = w * 1 - half + size_x;
  EXPECT_NEAR(0.5 * (west + east), 0.0, 1e-3) << "the terrain's centre, from the README's numbers";
  EXPECT_NEAR(east - west, (n - 1) * 2.0, 1.0) << "the terrain spans the field";
  for (const auto& tile : j["unity"]["tiles"]) {
    EXPECT_NEAR(tile["position_m"][0].get<double>(), w * tile["x"].get<int>() - half, 1e-3);
    EXPECT_NEAR(tile["position_m"][2].get<double>(), w * tile["z"].get<int>() - half, 1e-3);
  }
  fs::remove_all(dir);
}

// Unity's splat maps hold material 4s+k in channel k of RGBA (README step 4,
// Unity's alphamap order): a field whose material m weighs (m + 1)/36
// everywhere reads back as those weights, channel by channel.
TEST(Engines, UnitySplatChannelsAreTheMaterialsTheyClaim) {
  const int n = 65;
  const cv::Mat1f h(n, n, 10.f);
  terrain::Layers L;
  for (int m = 0; m < terrain::kNumMaterials; ++m) L.weight[size_t(m)] = cv::Mat1f(n, n, float(m + 1) / 36.f);
  const fs::path dir = test::temp_dir("unity-channels");
  StagedOutputs staged;
  stage_bundles(staged, dir / "c", {Engine::Unity}, {h, &L, 2.0, {}});
  staged.commit();
  for (int s = 0; s < 2; ++s) {
    const cv::Mat bgra = cv::imread((dir / "c.unity" / ("c.splat" + std::to_string(s) + ".png")).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(bgra.type(), CV_8UC4);
    cv::Mat rgba;
    cv::cvtColor(bgra, rgba, cv::COLOR_BGRA2RGBA);
    const cv::Scalar mean = cv::mean(rgba);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(mean[k], 255.0 * (4 * s + k + 1) / 36.0, 1.0) << "splat" << s << " channel " << k;
  }
  fs::remove_all(dir);
}

// Unreal: the nearest Landscape size, the heights as 16-bit PNG within one
// step of the field, one 8-bit weight layer per material summing to 255.
TEST(Engines, UnrealLandscapeSizeAndWeightLayers) {
  const int n = 1025;
  cv::Mat1f h(n, n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) h(r, c) = -80.f + 0.3f * r + 0.1f * c;
  const terrain::Layers L = weights(128);
  const fs::path dir = test::temp_dir("unreal");
  StagedOutputs staged;
  const nlohmann::json j = stage_bundles(staged, dir / "isle", {Engine::Unreal}, {h, &L, 5.0, {}});
  staged.commit();
  const fs::path b = dir / "isle.unreal";
  EXPECT_EQ(j["unreal"]["side_px"], 1009);
  const cv::Mat png = cv::imread((b / "isle.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(png.type(), CV_16UC1);
  ASSERT_EQ(png.cols, 1009);
  const double lo = j["unreal"]["range_m"][0], hi = j["unreal"]["range_m"][1];
  // Corners are kept; the plane stays a plane.
  EXPECT_NEAR(lo + png.at<uint16_t>(0, 0) * (hi - lo) / 65535, h(0, 0), (hi - lo) / 65535);
  EXPECT_NEAR(lo + png.at<uint16_t>(1008, 1008) * (hi - lo) / 65535, h(n - 1, n - 1), (hi - lo) / 65535);
  // Z scale: 16 bits span 512 m at 100 %; sea level at Z = 0.
  EXPECT_NEAR(double(j["unreal"]["scale_cm"][2]), (hi - lo) * 100 / 512, 1e-9);
  EXPECT_NEAR(double(j["unreal"]["location_cm"][2]), (hi + lo) * 50, 1e-9);
  cv::Mat1i sum(1009, 1009, 0);
  for (int m = 0; m < terrain::kNumMaterials; ++m) {
    const cv::Mat w = cv::imread((b / ("isle_" + std::string(terrain::material_name(m)) + ".png")).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(w.type(), CV_8UC1) << terrain::material_name(m);
    ASSERT_EQ(w.cols, 1009);
    cv::Mat1i wi;
    w.convertTo(wi, CV_32S);
    sum += wi;
  }
  double mn = 0, mx = 0;
  cv::minMaxLoc(sum, &mn, &mx);
  EXPECT_EQ(mn, 255);
  EXPECT_EQ(mx, 255);
  fs::remove_all(dir);
}

TEST(Engines, Terrain3DControlBitsFollowItsLayout) {
  // Terrain3D's table: base << 27, overlay << 22, blend << 14; the rest 0.
  EXPECT_EQ(terrain3d_encode({3, 5, 200}), (3u << 27) | (5u << 22) | (200u << 14));
  EXPECT_EQ(terrain3d_encode({31, 31, 255}), 0xFFFFC000u);
  for (int base = 0; base < 32; ++base)
    for (int overlay = 0; overlay < 32; overlay += 3)
      for (int blend = 0; blend < 256; blend += 17) {
        const uint32_t bits = terrain3d_encode({base, overlay, blend});
        const Terrain3DControl c = terrain3d_decode(bits);
        ASSERT_EQ(c.base, base);
        ASSERT_EQ(c.overlay, overlay);
        ASSERT_EQ(c.blend, blend);
        // reefgen's ids (0..7) never make a float NaN or infinity: EXR tools pass them through.
        float f;
        std::memcpy(&f, &bits, sizeof f);
        if (base < terrain::kNumMaterials && overlay < terrain::kNumMaterials) {
          ASSERT_TRUE(std::isfinite(f));
        }
      }
  EXPECT_EQ(terrain3d_region_side(257), 256);
  EXPECT_EQ(terrain3d_region_side(8193), 512);
  EXPECT_EQ(terrain3d_region_side(16385), 1024);
}

TEST(Engines, GodotBundleIsRegionAlignedAndItsControlMapDecodes) {
  const int n = 300;
  cv::Mat1f h(n, n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) h(r, c) = -50.f + 0.5f * r - 0.2f * c;
  const terrain::Layers L = weights(n);
  const fs::path dir = test::temp_dir("godot");
  StagedOutputs staged;
  const nlohmann::json j = stage_bundles(staged, dir / "isle", {Engine::Godot}, {h, &L, 10.0, {}});
  staged.commit();
  const fs::path b = dir / "isle.godot";
  const int side = j["godot"]["side_px"], pad = j["godot"]["padding_px"];
  EXPECT_EQ(side, 512);
  EXPECT_EQ(pad, 106);
  const cv::Mat1f height = read_exr_height(b / "isle.height.exr");
  const cv::Mat1f control = read_exr_height(b / "isle.control.exr");
  ASSERT_EQ(height.cols, side);
  ASSERT_EQ(control.cols, side);
  // The island sits centred and unchanged; the padding repeats its edge.
  EXPECT_EQ(cv::norm(height(cv::Rect(pad, pad, n, n)), h, cv::NORM_INF), 0);
  EXPECT_EQ(height(0, 0), h(0, 0));
  EXPECT_EQ(height(side - 1, side - 1), h(n - 1, n - 1));
  // Terrain3D puts the map's top-left sample on the region corner its Import
  // Position floors to (1.0.x: metres / spacing; main: samples), so sample
  // (x, z) lands at (x + corner, z + corner) · spacing; the island's centre
  // sample within one region of (0, 0).
  const int region = j["godot"]["region_side_px"], corner_at = j["godot"]["corner_px"][0];
  const double spacing = j["godot"]["vertex_spacing_m"];
  const long p10 = j["godot"]["import_position_m_terrain3d_1_0"][0];
  const int pmain = j["godot"]["import_position_px_terrain3d_main"][0];
  EXPECT_EQ(int(std::floor(float(p10) / float(spacing) / float(region))) * region, corner_at);
  EXPECT_EQ(int(std::floor(double(pmain) / region)) * region, corner_at);
  const int centre = pad + (n - 1) / 2;
  EXPECT_LE(std::abs(corner_at + centre), region / 2);
  EXPECT_DOUBLE_EQ(j["godot"]["island_centre_m"][0].get<double>(), (corner_at + centre) * spacing);
  // The README tells the user the same numbers.
  std::smatch m;
  const std::string readme = read_text(b / "README.txt");
  ASSERT_TRUE(std::regex_search(readme, m, std::regex(R"(1\.0\.x \(released; it reads metres\) \((-?\d+), (-?\d+)\))"))) << readme;
  EXPECT_EQ(std::stol(m[1]), p10);
  ASSERT_TRUE(std::regex_search(readme, m, std::regex(R"(samples x Vertex Spacing\) \((-?\d+), (-?\d+)\))"))) << readme;
  EXPECT_EQ(std::stoi(m[1]), pmain);
  for (int r = 0; r < n; r += 7)
    for (int c = 0; c < n; c += 5) {
      uint32_t bits;
      std::memcpy(&bits, &control(pad + r, pad + c), sizeof bits);
      const Terrain3DControl t = terrain3d_decode(bits);
      std::vector<std::pair<float, int>> w;
      for (int m = 0; m < terrain::kNumMaterials; ++m) w.push_back({-L.weight[size_t(m)](r, c), m});
      std::stable_sort(w.begin(), w.end());
      ASSERT_EQ(t.base, w[0].second) << r << "," << c;
      ASSERT_EQ(t.overlay, w[1].second) << r << "," << c;
      ASSERT_NEAR(t.blend, 255.0 * w[1].first / (w[0].first + w[1].first), 0.5 + 1e-6);
      ASSERT_EQ(bits & 0x3FFFu, 0u) << "UV, hole, navigation and autoshader bits must be 0";
    }
  uint32_t corner;
  std::memcpy(&corner, &control(0, 0), sizeof corner);
  EXPECT_EQ(corner, 0u) << "padding is deep sea floor";
  const cv::Mat colour = cv::imread((b / "isle.color.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(colour.type(), CV_8UC4);
  EXPECT_EQ(colour.cols, side);
  EXPECT_EQ(colour.at<cv::Vec4b>(side / 2, side / 2)[3], 128) << "alpha 0.5: roughness unchanged";
  fs::remove_all(dir);
}

namespace {

// The PNG of image `index` inside a GLB, decoded.
cv::Mat glb_image(const fs::path& glb, int index) {
  const std::string s = read_text(glb, size_t(1) << 30);
  uint32_t json_len;
  std::memcpy(&json_len, s.data() + 12, 4);
  const nlohmann::json j = nlohmann::json::parse(s.substr(20, json_len));
  const size_t bin = 20 + json_len + 8;
  const auto& view = j["bufferViews"][size_t(j["images"][size_t(index)]["bufferView"])];
  const std::string png = s.substr(bin + size_t(view["byteOffset"]), size_t(view["byteLength"]));
  return cv::imdecode(std::vector<uint8_t>(png.begin(), png.end()), cv::IMREAD_UNCHANGED);
}

}  // namespace

TEST(Engines, BlenderNormalTextureIsFlatOnAPlaneWhateverTheMeshSize) {
  // On a tilted plane the mesh's normal is the true normal everywhere, so
  // the tangent-space texture must read "straight up" (128, 128, 255) —
  // also past the GLB's 1025² vertex cap, where mesh and texture differ.
  for (const int n : {65, 1100}) {
    cv::Mat1f h(n, n);
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < n; ++c) h(r, c) = -60.f + 0.8f * r + 0.5f * c;
    terrain::Layers L = weights(n);
    // 5 m apart: 0.1 rise per metre east, 0.16 fall per metre north (rows run south).
    const cv::Vec3f up(-0.1f, 0.16f, 1.0f);
    L.normal = cv::Mat3f(n, n, up / float(cv::norm(up)));
    const fs::path dir = test::temp_dir("blender");
    StagedOutputs staged;
    const nlohmann::json j = stage_bundles(staged, dir / "isle", {Engine::Blender}, {h, &L, 5.0, {}});
    staged.commit();
    const fs::path b = dir / "isle.blender";
    EXPECT_EQ(int(j["blender"]["mesh_side_px"]), std::min(n, 1025));
    const Mesh m = read_glb(b / "isle.glb");
    EXPECT_EQ(m.positions.size(), size_t(std::min(n, 1025)) * size_t(std::min(n, 1025)));
    const cv::Mat normal = glb_image(b / "isle.glb", 1);
    ASSERT_EQ(normal.type(), CV_8UC3);
    ASSERT_EQ(normal.cols, n);
    for (int r = 1; r + 1 < n; r += 13)
      for (int c = 1; c + 1 < n; c += 11) {
        const cv::Vec3b v = normal.at<cv::Vec3b>(r, c);  // BGR
        ASSERT_NEAR(v[2], 128, 1) << n << " at " << r << "," << c;
        ASSERT_NEAR(v[1], 128, 1) << n << " at " << r << "," << c;
        ASSERT_GE(v[0], 254) << n << " at " << r << "," << c;
      }
    fs::remove_all(dir);
  }
}

TEST(Engines, BlenderNormalTextureRedIsEastGreenIsNorth) {
  // A flat mesh under normals leaning east, then north: glTF's tangent-space
  // convention (red = +u = east, green = up the image = north).
  const int n = 65;
  const cv::Mat1f h(n, n, -10.f);
  const float lean = 0.3f / std::sqrt(1.09f), upright = 1.f / std::sqrt(1.09f);
  const int want = int(std::lround((lean + 1) * 127.5f));
  for (const int axis : {0, 1}) {
    terrain::Layers L = weights(n);
    L.normal = cv::Mat3f(n, n, axis == 0 ? cv::Vec3f(lean, 0, upright) : cv::Vec3f(0, lean, upright));
    const fs::path dir = test::temp_dir("blender-axes");
    StagedOutputs staged;
    stage_bundles(staged, dir / "isle", {Engine::Blender}, {h, &L, 5.0, {}});
    staged.commit();
    const cv::Vec3b v = glb_image(dir / "isle.blender" / "isle.glb", 1).at<cv::Vec3b>(n / 2, n / 2);  // BGR
    EXPECT_NEAR(v[2], axis == 0 ? want : 128, 1) << "red, axis " << axis;
    EXPECT_NEAR(v[1], axis == 1 ? want : 128, 1) << "green, axis " << axis;
    fs::remove_all(dir);
  }
}

// ---- A world's tiled bundles (engines/world_bundle.hpp), at small tile sizes ----

namespace {

// An island on the west half of a 129² world: a cone whose valley runs east
// along row 64 across the middle of the world (and so across tile borders)
// to the sea. 10 m a sample.
cv::Mat1f valley_world(int n = 129) {
  cv::Mat1f h(n, n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      const double d = std::hypot(r - 64.0, c - 40.0);
      const double valley = c > 40 ? 12.0 * std::exp(-std::pow((r - 64.0) / 5.0, 2)) : 0.0;
      h(r, c) = float(120.0 * (1.0 - d / 75.0) - valley + 0.3 * std::sin(0.7 * r) * std::cos(0.5 * c));
    }
  return h;
}

struct World {
  cv::Mat1f h = valley_world();
  terrain::WorldLayerField field = terrain::world_layer_field(h, cv::Mat1f(), cv::Mat1b(), 10.0);
};

}  // namespace

TEST(WorldBundles, UnityTilesShareEdgesAndCarryTheirOwnSplats) {
  const World w;
  WorldTiling t;
  t.unity_tile_side = 65;
  const fs::path dir = test::temp_dir("world-unity");
  StagedOutputs staged;
  const auto j = stage_world_bundle(staged, dir / "w.unity", "w", Engine::Unity, {w.h, &w.field, 10.0, {}, {}, t});
  staged.commit();
  ASSERT_EQ(j["tiles_per_axis"], 2);
  ASSERT_EQ(j["side_px"], 129);  // no resampling: 2 · 64 + 1
  const int s = 65;
  auto sample = [&](int x, int z, int row, int col) {  // row 0 = south in the RAW
    const auto v = bytes_of(dir / "w.unity" / ("w_" + std::to_string(x) + "_" + std::to_string(z) + ".raw"));
    const size_t i = 2 * (size_t(row) * s + col);
    return int(v[i]) | int(v[i + 1]) << 8;
  };
  for (int i = 0; i < s; ++i) {
    ASSERT_EQ(sample(0, 0, i, s - 1), sample(1, 0, i, 0)) << i;
    ASSERT_EQ(sample(0, 0, s - 1, i), sample(0, 1, 0, i)) << i;
  }
  for (const char* stem : {"w_0_0", "w_1_1"})
    expect_splats_sum_to_255(dir / "w.unity" / (std::string(stem) + ".splat0.png"),
                             dir / "w.unity" / (std::string(stem) + ".splat1.png"), s - 1);
  fs::remove_all(dir);
}

TEST(WorldBundles, UnrealTilesMakeOneLandscapeWithTiledWeightLayers) {
  const World w;
  WorldTiling t;
  t.unreal_tile_px = 64, t.unreal_tiles_per_axis = 2;  // 128 = 127 quads + 1: one section per axis
  const fs::path dir = test::temp_dir("world-unreal");
  StagedOutputs staged;
  const auto j = stage_world_bundle(staged, dir / "w.unreal", "w", Engine::Unreal, {w.h, &w.field, 10.0, {}, {}, t});
  staged.commit();
  ASSERT_EQ(j["side_px"], 128);
  EXPECT_EQ(j["components_per_axis"], 1);
  // The tiles side by side are the heights resampled to 128², 16-bit.
  const cv::Mat1f want = resample_corners(w.h, 128);
  const double lo = j["range_m"][0], hi = j["range_m"][1];
  for (int ty = 0; ty < 2; ++ty)
    for (int tx = 0; tx < 2; ++tx) {
      const std::string xy = "_x" + std::to_string(tx) + "_y" + std::to_string(ty) + ".png";
      const cv::Mat png = cv::imread((dir / "w.unreal" / ("w" + xy)).string(), cv::IMREAD_UNCHANGED);
      ASSERT_EQ(png.type(), CV_16UC1) << xy;
      ASSERT_EQ(png.cols, 64);
      for (int r = 0; r < 64; ++r)
        for (int c = 0; c < 64; ++c)
          ASSERT_NEAR(lo + png.at<uint16_t>(r, c) * (hi - lo) / 65535.0, want(ty * 64 + r, tx * 64 + c),
                      (hi - lo) / 65535.0)
              << xy << " " << r << "," << c;
      cv::Mat1i sum(64, 64, 0);
      for (int m = 0; m < terrain::kNumMaterials; ++m) {
        const cv::Mat wl = cv::imread((dir / "w.unreal" / ("w_" + std::string(terrain::material_name(m)) + xy)).string(),
                                      cv::IMREAD_UNCHANGED);
        ASSERT_EQ(wl.type(), CV_8UC1) << terrain::material_name(m) << xy;
        cv::Mat1i wi;
        wl.convertTo(wi, CV_32S);
        sum += wi;
      }
      EXPECT_EQ(cv::countNonZero(sum != 255), 0) << xy;
    }
  fs::remove_all(dir);
}

// The gis bundle's layers are tiled like its heights, and each layer's VRT
// mosaic is the world's layer bit for bit: the drainage keeps flowing across
// tile borders (the valley crosses two of them).
TEST(WorldBundles, GisLayerTilesMosaicToTheWholeWorld) {
  const World w;
  WorldTiling t;
  t.gis_tile_max_px = 40;  // 4 × 4 tiles of 33 (the last 30)
  const fs::path dir = test::temp_dir("world-gis");
  StagedOutputs staged;
  const auto j = stage_world_bundle(staged, dir / "w.gis", "w", Engine::Gis, {w.h, &w.field, 10.0, {}, {}, t});
  staged.commit();
  EXPECT_EQ(j["tiles_per_axis"], nlohmann::json({4, 4}));
  const terrain::Layers whole = terrain::world_layers_tile(w.h, w.field, cv::Rect(0, 0, 129, 129));
  const cv::Mat1f flow = gis::read_geotiff(dir / "w.gis" / "w.flow.vrt").band;
  EXPECT_EQ(cv::norm(gis::read_geotiff(dir / "w.gis" / "w.height.vrt").band, w.h, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(flow, whole.flow_area_m2, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(gis::read_geotiff(dir / "w.gis" / "w.deposit.vrt").band, whole.deposit_m, cv::NORM_INF), 0.0);
  // The valley's drainage on both sides of the borders at columns 66 and 99
  // (land ends near column 107): growing downstream, no jump at a border.
  for (const int border : {66, 99}) {
    const float west = flow(64, border - 1), east = flow(64, border);
    EXPECT_GT(west, 50 * 100.f) << border;  // fifty cells drain through it at least
    EXPECT_GE(east, west) << border;
    EXPECT_LT(east, 1.25f * west) << border;
  }
  fs::remove_all(dir);
}

TEST(WorldBundles, LayerTilesShareTheWorldsScales) {
  const World w;
  WorldTiling t;
  t.gis_tile_max_px = 70;  // 2 × 2 tiles of 65 and 64
  const fs::path dir = test::temp_dir("world-layers");
  StagedOutputs staged;
  const auto j = stage_world_layers(staged, dir / "w.layers", "w", {w.h, &w.field, 10.0, {}, {}, t}, false);
  staged.commit();
  ASSERT_EQ(j["layer_tiles"].size(), 4u);
  const double log_max = j["layers"]["flow"]["log10_max"];
  double flow_max = 0;
  cv::minMaxLoc(w.field.flow_area_m2, nullptr, &flow_max);
  EXPECT_NEAR(log_max, std::log10(flow_max / 100.0), 1e-9);
  for (const auto& tile : j["layer_tiles"]) {
    const std::string s0 = tile["files"]["splat0"], s1 = tile["files"]["splat1"];
    const int side = tile["x"] == 0 ? 65 : 64;
    expect_splats_sum_to_255(dir / "w.layers" / s0, dir / "w.layers" / s1, side);
  }
  // The flow is encoded on the world's scale: across the border at column
  // 65, the valley's code changes as little as its area does.
  const cv::Mat a = cv::imread((dir / "w.layers" / "w_x0_y0.flow.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat b = cv::imread((dir / "w.layers" / "w_x1_y0.flow.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(a.type(), CV_16UC1);
  EXPECT_NEAR(a.at<uint16_t>(64, 64), b.at<uint16_t>(64, 0), 0.02 * 65535);
  EXPECT_GT(a.at<uint16_t>(64, 64), 0.4 * 65535);
  // 0 is the sea only: every land pixel of every tile has a code of at least 1.
  for (const auto& tile : j["layer_tiles"]) {
    const cv::Mat f = cv::imread((dir / "w.layers" / tile["files"]["flow"].get<std::string>()).string(), cv::IMREAD_UNCHANGED);
    const int x0 = tile["x"] == 0 ? 0 : 65, y0 = tile["y"] == 0 ? 0 : 65;
    for (int y = 0; y < f.rows; ++y)
      for (int x = 0; x < f.cols; ++x)
        ASSERT_EQ(f.at<uint16_t>(y, x) == 0, !(w.h(y0 + y, x0 + x) > 0)) << "tile " << tile << " at " << x << "," << y;
  }
  EXPECT_FALSE(fs::exists(dir / "w.layers" / "w_x0_y0.flow.tif"));
  EXPECT_THROW(stage_world_bundle(staged, dir / "w.blender", "w", Engine::Blender, {w.h, &w.field, 10.0, {}, {}, t}),
               reefgen::Error);
  fs::remove_all(dir);
}

// Terrain3D: tiles of whole regions, each with its height (metres), control
// and colour maps and an import position at its centre; side by side they
// are the world resampled to the tiles' side.
TEST(WorldBundles, GodotTilesAreWholeRegionsImportedAtTheirCorners) {
  const World w;
  WorldTiling t;
  t.godot_region_px = 32, t.godot_tile_px = 64, t.godot_tiles_per_axis = 2;
  const fs::path dir = test::temp_dir("world-godot");
  StagedOutputs staged;
  const auto j = stage_world_bundle(staged, dir / "w.godot", "w", Engine::Godot, {w.h, &w.field, 10.0, {}, {}, t});
  staged.commit();
  ASSERT_EQ(j["side_px"], 128);
  ASSERT_EQ(j["tiles"].size(), 4u);
  const cv::Mat1f want = resample_corners(w.h, 128);
  const double spacing = j["vertex_spacing_m"];
  EXPECT_NEAR(spacing, 10.0 * 128 / 127, 1e-9);
  for (const auto& tile : j["tiles"]) {
    const int i = tile["x"], y = tile["y"];
    const cv::Mat1f ht = read_exr_height(dir / "w.godot" / tile["heightmap"].get<std::string>());
    ASSERT_EQ(ht.cols, 64);
    EXPECT_EQ(cv::norm(ht, want(cv::Rect(i * 64, y * 64, 64, 64)), cv::NORM_INF), 0.0);
    const cv::Mat1f control = read_exr_height(dir / "w.godot" / tile["control_map"].get<std::string>());
    for (int r = 0; r < 64; ++r)
      for (int c = 0; c < 64; ++c) {
        uint32_t bits;
        std::memcpy(&bits, &control(r, c), sizeof bits);
        const Terrain3DControl d = terrain3d_decode(bits);
        ASSERT_LT(d.base, terrain::kNumMaterials);
        ASSERT_LT(d.overlay, terrain::kNumMaterials);
      }
    // Each tile's top-left sample on its region corner: the tiles meet edge
    // to edge round (0, 0) in either importer.
    EXPECT_EQ(tile["corner_px"][0].get<int>(), i * 64 - 64);
    EXPECT_EQ(tile["corner_px"][1].get<int>(), y * 64 - 64);
    EXPECT_EQ(int(std::floor(tile["import_position_m_terrain3d_1_0"][0].get<long>() / spacing / 64)), i - 1);
    EXPECT_EQ(int(std::floor(tile["import_position_px_terrain3d_main"][1].get<int>() / 64.0)), y - 1);
    EXPECT_DOUBLE_EQ(tile["centre_m"][0].get<double>(), (i * 64 + 32 - 64) * spacing);
    EXPECT_DOUBLE_EQ(tile["centre_m"][2].get<double>(), (y * 64 + 32 - 64) * spacing);
    EXPECT_TRUE(fs::exists(dir / "w.godot" / tile["color_map"].get<std::string>()));
  }
  fs::remove_all(dir);
}

// Terrain3D's importers, as their code reads the Import Position (1.0.0–1.0.2
// importer.gd passes it as metres; main after 2fdda09 multiplies samples by
// the spacing; Terrain3DData::import_images descales by the spacing in
// float and floors each slice to its region): the map's corner lands on the
// region we planned, for spacings from 0.5 m to 94 m and any centre.
TEST(Engines, Terrain3DPositionsLandOnThePlannedRegion) {
  for (const int region : {256, 512, 1024})
    for (const double spacing : {0.5, 1.0, 2.9296875, 5.859375, 23.4375, 93.75})
      for (const int centre : {0, 127, 128, 1024, 4095, 8191}) {
        const Terrain3DPlacement at = terrain3d_placement(centre, region, spacing);
        EXPECT_EQ(at.corner_px % region, 0);
        EXPECT_LE(std::abs(at.corner_px + centre), region / 2) << centre;
        const float v = float(spacing);
        EXPECT_EQ(int(std::floor(float(at.position_1_0_m) / v / float(region))) * region, at.corner_px)
            << region << " " << spacing << " " << centre;
        EXPECT_EQ(int(std::floor(float(at.position_main_px) * v / v / float(region))) * region, at.corner_px);
        EXPECT_DOUBLE_EQ(at.centre_m, (at.corner_px + centre) * spacing);
        EXPECT_EQ(at.within_clamp, std::labs(at.position_1_0_m) <= 8192);
      }
  EXPECT_THROW(terrain3d_placement(0, 256, 1.0, 100), Error);
  EXPECT_THROW(terrain3d_placement(0, 0, 1.0), Error);
}
