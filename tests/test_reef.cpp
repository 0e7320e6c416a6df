// Reef geomorphology (procgen/reef.hpp, docs/REEF.md) and the reef report
// (terrain/reef_stats.hpp): the real-reef bars on the presets at test sizes.
#include <gtest/gtest.h>

#include <fstream>

#include <nlohmann/json.hpp>

#include "reefgen/labels.hpp"
#include "test_util.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/reef.hpp"
#include "reefgen/terrain/ocean_floor.hpp"
#include "reefgen/terrain/reef_stats.hpp"

using namespace reefgen;
using namespace reefgen::procgen;

namespace {

IslandSpec preset(const std::string& name) {
  std::ifstream f(std::string(REEFGEN_SOURCE_DIR) + "/configs/presets/" + name + ".json");
  return spec_from_json(nlohmann::json::parse(f), name);
}

RenderOptions side(int px) {
  RenderOptions o;
  o.size_px = px;
  return o;
}

// The atoll preset with no random passes or motu and one drawn motu.
IslandSpec atoll_with_one_motu(double angle_deg, double length_m) {
  IslandSpec s = preset("atoll");
  s.reef.random_passes = 0;
  s.reef.random_motu = 0;
  Motu m;
  m.angle_deg = angle_deg;
  m.length_m = length_m;
  s.reef.motu = {m};
  return s;
}
}  // namespace

TEST(Reef, LagoonDepthGrowsWithAreaAndAge) {
  EXPECT_NEAR(lagoon_depth_for_area_m(10), 30, 1e-9);
  EXPECT_NEAR(lagoon_depth_for_area_m(100), 42, 1e-9);
  EXPECT_EQ(lagoon_depth_for_area_m(1e9), 90);
  EXPECT_EQ(lagoon_depth_for_area_m(1e-3), 8);
  IslandSpec s;
  s.subsidence = 0;
  const double young = lagoon_depth_m(s);
  s.subsidence = 0.6;
  const double old = lagoon_depth_m(s);
  EXPECT_NEAR(young, s.reef.young_lagoon_share * old, 1e-9);
  s.reef.lagoon_depth_m = 40;
  EXPECT_NEAR(lagoon_depth_m(s), 40, 1e-9);
}

TEST(Reef, ShoreKeepsLagoonUnderWater) {
  const ReefParams r;
  for (double h : {-50.0, -3.0, 5.0, 120.0})
    for (double xt = 2.0; xt <= 3.5; xt += 0.05) EXPECT_LE(shore_height_m(h, xt, 20, r), 0.0) << h << " " << xt;
  // Inland of coast_begin land is untouched; at the shore it is 0.
  EXPECT_EQ(shore_height_m(80, r.coast_begin - 0.01, 20, r), 80);
  EXPECT_NEAR(shore_height_m(80, 2.0, 20, r), 0, 1e-12);
  // The shoreface reaches the floor.
  EXPECT_NEAR(shore_height_m(80, 2.0 + r.shoreface, 20, r), -20, 1e-12);
}

TEST(Reef, ReefCoralHasAFlatAndACrestAwash) {
  CoralParams c;
  c.back_m = -25;
  EXPECT_EQ(reef_coral_m(c.back_end, c), -25);
  EXPECT_EQ(reef_coral_m(c.flat_begin, c), c.flat_m);
  EXPECT_EQ(reef_coral_m(0.5 * (c.crest_begin + c.crest_end), c), c.crest_m);
  EXPECT_GE(c.crest_m, -1.0);
  EXPECT_LE(c.crest_m, 1.0);
  EXPECT_EQ(reef_coral_m(1.0, c), c.abyss_m);
  // The flat's first half stays within 0.1 m of flat_m: a flat, not a ramp.
  EXPECT_NEAR(reef_coral_m(0.5 * (c.flat_begin + c.crest_begin), c), c.flat_m, 0.1);
}

// The atoll bars of the reef issue at 513² (the test size; docs/REEF.md has
// the 1025² figures): crest at −1 m or higher on ≥ 70 % of rays, lagoon median
// ≥ 5 m below the crest's and within [−60, −8] m, motu above the sea, passes,
// and no flat floor.
TEST(Reef, AtollPresetMeetsTheRealReefBars) {
  const IslandSpec s = preset("atoll");
  const IslandFields f = generate(s, side(513));
  const auto st = terrain::reef_stats(f.height_m, s.world_size_m / 513);
  EXPECT_GE(st.crest_at_sea, 0.70);
  EXPECT_LE(st.lagoon_median_m, st.crest_median_m - 5);
  EXPECT_LE(st.lagoon_median_m, -8);
  EXPECT_GE(st.lagoon_median_m, -60);
  EXPECT_GE(st.motu, 3);
  EXPECT_GE(st.passes, 1);
  EXPECT_LE(st.flat_floor_share, 0.02);
  // Motu are labelled beach (the green a painter puts on a reef ring).
  int motu_beach = 0;
  for (int y = 0; y < 513; ++y)
    for (int x = 0; x < 513; ++x) motu_beach += f.height_m(y, x) > 0.5f && f.label(y, x) == kBeach;
  EXPECT_GT(motu_beach, 100);
}

// A bright (young) island's painted lagoon is water: every lagoon-labelled
// cell below the sea, at every subsidence.
TEST(Reef, LagoonIsWaterAtEveryAge) {
  for (double lambda : {0.0, 0.15, 0.4, 0.9}) {
    IslandSpec s = preset("young-volcano");
    s.subsidence = lambda;
    const IslandFields f = generate(s, side(257));
    int64_t lagoon = 0, wet = 0;
    for (int y = 0; y < 257; ++y)
      for (int x = 0; x < 257; ++x)
        if (f.label(y, x) == kLagoon) ++lagoon, wet += f.height_m(y, x) < 0;
    ASSERT_GT(lagoon, 0);
    EXPECT_GE(double(wet) / double(lagoon), 0.99) << "subsidence " << lambda;
  }
}

TEST(Reef, SeaFloorIsNeverAFlatPlane) {
  for (const char* name : {"atoll", "barrier-reef", "young-volcano", "low-island", "windswept"}) {
    const IslandSpec s = preset(name);
    const IslandFields f = generate(s, side(257));
    const auto st = terrain::reef_stats(f.height_m, s.world_size_m / 257);
    EXPECT_LE(st.flat_floor_share, 0.02) << name;
    double lo, hi;
    cv::minMaxLoc(f.height_m, &lo, &hi);
    EXPECT_GT(lo, s.heights.floor_m - 1e-3) << name;  // the training range's floor is kept
  }
}

TEST(Reef, DrawnPassesAndMotuAreWhereTheSpecPutsThem) {
  IslandSpec s = atoll_with_one_motu(90, 700);
  PassStroke p;
  p.points = {{-0.4, 0.0}, {-0.9, 0.0}};  // across the western rim
  s.reef.passes = {p};
  const IslandFields f = generate(s, side(513));
  const auto st = terrain::reef_stats(f.height_m, s.world_size_m / 513);
  EXPECT_EQ(st.motu, 1);
  EXPECT_EQ(st.passes, 1);
  // The motu stands north of the centre, the pass is water to its floor.
  float north = -1e9f, west_crest = -1e9f;
  for (int y = 0; y < 256; ++y) north = std::max(north, f.height_m(y, 256));
  const OutlineTable o(s.outlines, s.min_gap);
  const double r_crest = o.radii(M_PI)[2] + 0.5 * (s.coral.crest_begin + s.coral.crest_end) * (o.radii(M_PI)[3] - o.radii(M_PI)[2]);
  const int xc = int(std::lround((1.0 - r_crest) * 256));
  for (int x = std::max(0, xc - 3); x <= xc + 3; ++x) west_crest = std::max(west_crest, f.height_m(256, x));
  EXPECT_GT(north, 1.0f);
  EXPECT_LT(west_crest, -5.0f);
}

// A motu on the west of the rim, where the angle from the centre jumps by
// 2π: its top leans from the storm ridge to the lagoon (a dead-flat top
// read as a filled, straight flat channel) and has no seam along that line
// (noises of the angle drew one: a 0.26 m step across the top at 1025²,
// against second differences of 0.02 m elsewhere on it).
TEST(Reef, AMotuLeansToItsLagoonAndHasNoSeamWestOfTheCentre) {
  const IslandSpec s = atoll_with_one_motu(180, 900);
  constexpr int kSide = 1025;
  const IslandFields f = generate(s, side(kSide));
  const double cell_m = s.world_size_m / kSide;
  int top = 0, flat = 0;
  double worst_seam = 0, worst_elsewhere = 0;
  for (int y = 2; y < kSide - 2; ++y)
    for (int x = 2; x < kSide / 2; ++x) {
      bool inside = true;
      for (int j = -2; j <= 2; ++j)
        for (int i = -2; i <= 2; ++i) inside &= f.height_m(y + j, x + i) > 0.5f;
      if (!inside) continue;
      ++top;
      const double gx = (f.height_m(y, x + 1) - f.height_m(y, x - 1)) / (2 * cell_m);
      const double gy = (f.height_m(y + 1, x) - f.height_m(y - 1, x)) / (2 * cell_m);
      flat += std::hypot(gx, gy) < 0.005;
      const double d2 = std::abs(f.height_m(y + 1, x) - 2 * f.height_m(y, x) + f.height_m(y - 1, x));
      double& worst = std::abs(y - kSide / 2) <= 1 ? worst_seam : worst_elsewhere;
      worst = std::max(worst, d2);
    }
  ASSERT_GT(top, 100);
  EXPECT_LT(double(flat) / top, 0.2) << flat << " of " << top << " top cells under a 0.5 % slope";
  EXPECT_LT(worst_seam, 2 * worst_elsewhere + 0.02) << "across the row through the centre";
}

TEST(Reef, SameSpecSameBytesAndJsonRoundTrip) {
  IslandSpec s = preset("barrier-reef");
  s.reef.motu.push_back(Motu{});
  nlohmann::json j;
  to_json(j, s);
  const IslandSpec back = spec_from_json(j, "round-trip");
  nlohmann::json j2;
  to_json(j2, back);
  EXPECT_EQ(j, j2);
  const IslandFields a = generate(s, side(129)), b = generate(back, side(129));
  EXPECT_EQ(cv::norm(a.height_m, b.height_m, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a.label, b.label, cv::NORM_INF), 0);
  nlohmann::json bad = j;
  bad["reef"]["motu"][0]["height_m"] = 50;
  EXPECT_THROW(spec_from_json(bad, "bad.json"), Error);
  bad = j;
  bad["reef"]["lagoon_dept_m"] = 3;  // a typo is refused, not ignored
  EXPECT_THROW(spec_from_json(bad, "bad.json"), Error);
}

TEST(ReefStats, RefusesEmptyAndBadCellSize) {
  EXPECT_THROW(terrain::reef_stats(cv::Mat1f(), 1), Error);
  EXPECT_THROW(terrain::reef_stats(cv::Mat1f(8, 8, 0.f), 0), Error);
}

// A fringing reef: a cone island (200 m) whose beach meets a −0.8 m reef
// flat 100 m wide, its crest at −0.3 m, the fore reef down to −100 m. The
// island's land lies within the crest's search band; the crest is the
// reef's, not the land's (it read the land, +15 m, on a painted fringing
// reef before).
TEST(ReefStats, AFringingReefsCrestIsNotTheIslandsBeach) {
  constexpr double kCellM = 10;
  cv::Mat1f h(301, 301);
  for (int y = 0; y < 301; ++y)
    for (int x = 0; x < 301; ++x) {
      const double r_m = kCellM * std::hypot(x - 150.0, y - 150.0);
      double z;
      if (r_m < 800) z = 2 + 198 * (1 - r_m / 800);            // the island, 2 m at its beach
      else if (r_m < 900) z = -0.8;                            // reef flat
      else if (r_m < 930) z = -0.3;                            // crest
      else z = std::max(-100.0, -0.3 - 0.5 * (r_m - 930));     // fore reef
      h(y, x) = float(z);
    }
  const auto st = terrain::reef_stats(h, kCellM);
  ASSERT_GT(st.rays_with_reef, 300);
  EXPECT_NEAR(st.crest_median_m, -0.3, 0.1);
  EXPECT_GT(st.crest_at_sea, 0.95);
}

// The grid measure finds a planted 8-px waffle of 5 cm on an underwater slope
// and reports ~0 without it.
TEST(ReefStats, GridAmplitudeFindsAPlantedWaffle) {
  cv::Mat1f h(512, 512);
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x) h(y, x) = -10.f - 0.1f * float(x) + 0.5f * std::sin(0.05f * float(y)) * std::cos(0.031f * float(x));
  const auto clean = terrain::reef_stats(h, 3, 8);
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x) h(y, x) += 0.05f * std::cos(2.f * float(M_PI) * float(x) / 8.f);
  const auto waffle = terrain::reef_stats(h, 3, 8);
  EXPECT_LT(clean.grid_amplitude_m, 0.005);
  EXPECT_NEAR(waffle.grid_amplitude_m, 0.05, 0.01);
  EXPECT_GT(waffle.grid_ring_ratio, 10);
}

// --ocean-floor-m: the open ocean is stretched to the depth asked, continuous
// at the knee; a lagoon behind its rim keeps its depth even below the knee.
TEST(OceanFloor, StretchesTheOpenOceanAndKeepsLagoons) {
  cv::Mat1f h(64, 64, -100.f);
  // A rim at -1 m around a -70 m lagoon in the middle; the ocean rises to -60 m at the rim.
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const double r = std::hypot(x - 31.5, y - 31.5);
      if (r < 12) h(y, x) = -70.f;
      else if (r < 16) h(y, x) = -1.f;
      else h(y, x) = float(-60.0 - 40.0 * std::min(1.0, (r - 16) / 16));
    }
  cv::Mat1f d = h.clone();
  terrain::deepen_flank(d, -2000);
  EXPECT_FLOAT_EQ(d(0, 0), -2000.f);       // the model's floor lands on the ocean floor
  EXPECT_FLOAT_EQ(d(31, 31), -70.f);       // the lagoon is not the ocean
  EXPECT_FLOAT_EQ(d(31, 31 + 14), -1.f);   // nor the rim
  // Continuous at the knee: the flank's first cells stay near -60 m.
  EXPECT_NEAR(d(31, 31 + 17), -60.0 + (h(31, 31 + 17) + 60.0) * 1940.0 / 40.0, 1e-3);
  EXPECT_FLOAT_EQ(d(31, 31 + 16), h(31, 31 + 16));  // at the knee itself: unchanged
  double lo, hi;
  cv::minMaxLoc(d, &lo, &hi);
  EXPECT_FLOAT_EQ(float(lo), -2000.f);
  cv::Mat1f same = h.clone();
  terrain::deepen_flank(same, -90);  // shallower than the ocean already is: nothing
  EXPECT_EQ(cv::norm(same, h, cv::NORM_INF), 0);
  EXPECT_THROW(terrain::deepen_flank(same, std::nan("")), Error);
  EXPECT_THROW(terrain::deepen_flank(same, -20000), Error);
  // Above the knee nothing could be stretched: refused, not ignored.
  EXPECT_THROW(terrain::deepen_flank(same, -59), Error);
  EXPECT_THROW(terrain::deepen_flank(same, -1), Error);
  // An ocean a hair below the knee is stretched as if it reached -100 m,
  // not one cell to the floor asked (an 11 km needle).
  cv::Mat1f shallow(64, 64, -20.f);
  shallow(0, 0) = -60.00001f;
  terrain::deepen_flank(shallow, -11000);
  EXPECT_GT(shallow(0, 0), -61.f);
}

// Drawn passes are bounded (each reef cell looks at the passes near it): too
// many points in all, or a pass wider than a real one, is one clear error.
TEST(Reef, DrawnPassesAreBounded) {
  nlohmann::json j = {{"reef", {{"passes", nlohmann::json::array()}}}};
  for (int k = 0; k < 5; ++k) {
    nlohmann::json pts = nlohmann::json::array();
    for (int i = 0; i < 1000; ++i) pts.push_back({0.5 * std::cos(0.01 * i), 0.5 * std::sin(0.01 * i)});
    j["reef"]["passes"].push_back({{"points", pts}});
  }
  test::expect_error_naming([&] { spec_from_json(j, "many.json"); }, "4096");
  nlohmann::json wide = {{"reef", {{"passes", {{{"points", {{0, 0}, {1, 0}}}, {"width_m", 5000}}}}}}};
  test::expect_error_naming([&] { spec_from_json(wide, "wide.json"); }, "width_m");
}
