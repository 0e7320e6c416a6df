// Other island systems: Wilbur-style islands and height-band sketches.
#include <gtest/gtest.h>

#include "reefgen/files.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/islands/terrains.hpp"
#include "test_util.hpp"

using namespace reefgen;
using namespace reefgen::islands;

namespace {
int land_pixels(const cv::Mat1f& h) {
  int land = 0;
  for (float v : h) land += v > 0;
  return land;
}
}  // namespace

TEST(Wilbur, GoldenValuesAndDeterminism) {
  WilburParams p;
  p.size_px = 64;
  const cv::Mat1f h = wilbur_height(p, 1);
  // Golden values (seed 1, 64 px, defaults): a change in the recipe shows here.
  EXPECT_EQ(land_pixels(h), 1589);
  EXPECT_NEAR(h(32, 32), 14.760653, 1e-3);
  EXPECT_NEAR(h(10, 50), -46.610176, 1e-3);
  EXPECT_EQ(h(0, 0), -100.0f);  // corners: s = n - r² < -0.5, the ocean floor
  EXPECT_EQ(cv::norm(h, wilbur_height(p, 1), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(h, wilbur_height(p, 2), cv::NORM_INF), 0.0);
}

TEST(Wilbur, RecipeProperties) {
  WilburParams p;
  p.size_px = 96;
  const cv::Mat1f h3 = wilbur_height(p, 4);
  double lo, hi;
  cv::minMaxLoc(h3, &lo, &hi);
  EXPECT_GE(lo, -p.depth_m);
  EXPECT_LE(hi, p.peak_m);  // s ≤ 1
  // The exponent only reshapes land: same coastline, lower mean land height for larger p.
  p.exponent = 1;
  const cv::Mat1f h1 = wilbur_height(p, 4);
  double sum1 = 0, sum3 = 0;
  int n = 0;
  for (int r = 0; r < h1.rows; ++r)
    for (int c = 0; c < h1.cols; ++c) {
      EXPECT_EQ(h1(r, c) > 0, h3(r, c) > 0);
      if (h1(r, c) > 0) sum1 += h1(r, c), sum3 += h3(r, c), ++n;
    }
  ASSERT_GT(n, 0);
  EXPECT_LT(sum3, sum1);
  EXPECT_THROW(wilbur_height(WilburParams{64, 0}, 1), reefgen::Error);
}

TEST(HeightToSketch, BandsGiveTheFiveRegions) {
  cv::Mat1f h(1, 7);
  const float v[7] = {100, 8, 7.9f, 0, -11.9f, -12, -40};
  for (int c = 0; c < 7; ++c) h(0, c) = v[c];
  const Sketch s = height_to_sketch(h, 0.4);
  const int want[7] = {kIsland, kIsland, kBeach, kBeach, kLagoon, kReef, kAbyss};
  for (int c = 0; c < 7; ++c) EXPECT_EQ(s.label(0, c), want[c]) << "height " << v[c];
  EXPECT_EQ(s.subsidence(0, 3), 0.4f);
  EXPECT_THROW(height_to_sketch(h, 0.4, SketchBands{8, 50, 40}), reefgen::Error);
}

TEST(Mapgen4, GoldenValuesAndDeterminism) {
  Mapgen4Params p;
  p.size_px = 64;
  const cv::Mat1f h = mapgen4_height(p, 1);
  // Golden values (seed 1, 64 px, defaults; dual mesh with centroid Voronoi vertices since 2026-11-23).
  EXPECT_EQ(land_pixels(h), 1493);
  EXPECT_NEAR(h(32, 32), 207.122208, 1e-2);
  EXPECT_NEAR(h(10, 50), 11.373843, 1e-2);
  EXPECT_EQ(h(0, 0), -100.0f);
  EXPECT_EQ(cv::norm(h, mapgen4_height(p, 1), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(h, mapgen4_height(p, 2), cv::NORM_INF), 0.0);
  double lo, hi;
  cv::minMaxLoc(h, &lo, &hi);
  EXPECT_GE(lo, -p.depth_m);
  EXPECT_LE(hi, p.peak_m);
  EXPECT_THROW(mapgen4_height(Mapgen4Params{64, 0.001}, 1), reefgen::Error);
}

TEST(Mapgen4, PoissonDiskKeepsItsDistanceAndFillsTheSquare) {
  const auto pts = poisson_disk(0.1, 3);
  EXPECT_EQ(pts.size(), poisson_disk(0.1, 3).size());
  double min_d = 1e9;
  for (size_t i = 0; i < pts.size(); ++i) {
    EXPECT_TRUE(std::abs(pts[i].x) <= 1 && std::abs(pts[i].y) <= 1);
    for (size_t j = i + 1; j < pts.size(); ++j) min_d = std::min(min_d, std::hypot(pts[i].x - pts[j].x, pts[i].y - pts[j].y));
  }
  EXPECT_GE(min_d, 0.1);
  // Maximal sampling: about area / (0.7·r²) points, never far from that.
  EXPECT_GT(pts.size(), 4.0 / (0.1 * 0.1) * 0.5);
  EXPECT_LT(pts.size(), 4.0 / (0.1 * 0.1) * 1.0);
}

TEST(TerrainParams, JsonConfigsRoundTripAndErrors) {
  for (const std::string kind : {"wilbur", "mapgen4"}) {
    const auto j = kind == "wilbur" ? to_json(WilburParams{}) : to_json(Mapgen4Params{});
    // The shipped config is the defaults serialised.
    EXPECT_EQ(read_json(std::string(REEFGEN_SOURCE_DIR) + "/configs/terrains/" + kind + ".json"), j) << kind;
    EXPECT_EQ(cv::norm(configured_terrain(kind, j, "cfg", 48, 3), named_terrain(kind, 48, 3), cv::NORM_INF), 0.0) << kind;
    try {
      configured_terrain(kind, {{"octavs", 3}}, "cfg.json", 48, 3);
      ADD_FAILURE() << "unknown key accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("octavs"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(configured_terrain("wilbur", {{"octaves", 0}}, "cfg.json", 48, 3), Error);
  EXPECT_THROW(configured_terrain("mapgen4", {{"spacing", "wide"}}, "cfg.json", 48, 3), Error);
  EXPECT_THROW(configured_terrain("perlin", nlohmann::json::object(), "cfg.json", 48, 3), Error);
}

TEST(TerrainParams, EveryShippedConfigMakesAnIsland) {
  // configs/terrains/KIND[-variant].json: the kind is the name's first word.
  int n = 0;
  for (const auto& e : fs::directory_iterator(std::string(REEFGEN_SOURCE_DIR) + "/configs/terrains")) {
    const std::string name = e.path().stem().string(), kind = name.substr(0, name.find('-'));
    const cv::Mat1f h = configured_terrain(kind, read_json(e.path()), e.path().string(), 64, 5);
    double lo, hi;
    cv::minMaxLoc(h, &lo, &hi);
    EXPECT_GT(hi, 0.0) << name << ": no land";
    EXPECT_LT(lo, 0.0) << name << ": no sea";
    ++n;
  }
  EXPECT_GE(n, 6);
}

// The terrains' configs: every field off its default comes back (the one
// params mechanism, common/params_json.hpp).
TEST(Terrains, ParamsRoundTripEveryField) {
  reefgen::test::expect_params_round_trip<WilburParams>(
      [](const nlohmann::json& j) { return params_from_json<WilburParams>(j, "w.json", "configs/terrains/"); });
  reefgen::test::expect_params_round_trip<Mapgen4Params>(
      [](const nlohmann::json& j) { return params_from_json<Mapgen4Params>(j, "m.json", "configs/terrains/"); });
  reefgen::test::expect_error_naming([] { params_from_json<Mapgen4Params>(nlohmann::json{{"falloff", "round"}}, "m.json", "x"); },
                      "m.json: falloff = 'round'; use chebyshev or euclidean");
}
