// Reef geomorphology (procgen/reef.hpp, docs/REEF.md) and the reef report
// (terrain/reef_stats.hpp): the real-reef bars on the presets at test sizes.
#include <gtest/gtest.h>

#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

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

// The rim's zones add up to the band; the flat is flat_width_m × (1 +
// gain · facing) where the band has room, the back-reef slope takes what is
// left; a narrower band narrows the flat first, then every zone alike.
TEST(Reef, RimZonesFillTheBandAndTheFlatGivesWayFirst) {
  const ReefParams r;
  for (double facing : {-1.0, 0.0, 0.6}) {
    const RimWidths w = rim_widths_m(2000, facing, r);
    EXPECT_NEAR(w.fore + w.crest + w.flat + w.back, 2000, 1e-9);
    EXPECT_NEAR(w.flat, r.flat_width_m * (1 + r.windward_flat_gain * facing), 1e-9) << facing;
    EXPECT_EQ(w.fore, r.fore_reef_m + kDropOffWidthM);
    EXPECT_EQ(w.crest, r.crest_width_m);
  }
  const RimWidths narrow = rim_widths_m(400, 0.0, r);
  EXPECT_NEAR(narrow.fore + narrow.crest + narrow.flat + narrow.back, 400, 1e-9);
  EXPECT_EQ(narrow.back, kMinBackReefM);
  EXPECT_NEAR(narrow.flat, 400 - r.fore_reef_m - kDropOffWidthM - r.crest_width_m - kMinBackReefM, 1e-9);
  const RimWidths tiny = rim_widths_m(200, 0.0, r);
  EXPECT_EQ(tiny.flat, 0);
  EXPECT_NEAR(tiny.fore + tiny.crest + tiny.back, 200, 1e-9);
  EXPECT_NEAR(tiny.fore / tiny.back, (r.fore_reef_m + kDropOffWidthM) / kMinBackReefM, 1e-12);
}

// Across the rim: the seaward slope rises from −rim_edge_depth_m at R₄ past
// the terrace's foot (−fore_reef_depth_m) to the crest (awash), the flat lies at
// flat_m beyond its first quarter, the
// back-reef slope ends at the lagoon's edge; no step anywhere (1 m apart,
// nothing moves more than the steepest zone allows).
TEST(Reef, RimHeightRisesToAnAwashCrestAndAFlatThenFallsToTheLagoon) {
  const ReefParams r;
  const CoralParams c;
  const RimWidths w = rim_widths_m(900, 0.0, r);
  const double back_m = -22;
  EXPECT_NEAR(rim_height_m(0, w, c, back_m, r, 0, 0), -rim_edge_depth_m(r), 1e-12);
  // The terrace's foot, kDropOffWidthM in from the edge.
  EXPECT_NEAR(rim_height_m(kDropOffWidthM, w, c, back_m, r, 0, 0), -r.fore_reef_depth_m, 1e-9);
  EXPECT_NEAR(rim_height_m(w.fore + 0.5 * w.crest, w, c, back_m, r, 0, 0), c.crest_m, 1e-12);
  EXPECT_GE(c.crest_m, -1.0);
  EXPECT_NEAR(rim_height_m(w.fore + w.crest + 0.6 * w.flat, w, c, back_m, r, 0, 0), c.flat_m, 1e-12);
  EXPECT_NEAR(rim_height_m(900, w, c, back_m, r, 0, 0), back_m, 1e-9);
  // The crest's and the flat's relief move them, nothing else.
  EXPECT_NEAR(rim_height_m(w.fore + 0.5 * w.crest, w, c, back_m, r, 0.2, -0.1), c.crest_m + 0.2, 1e-12);
  double prev = rim_height_m(0, w, c, back_m, r, 0, 0), steepest = 0;
  for (double s = 1; s <= 900; s += 1) {
    const double h = rim_height_m(s, w, c, back_m, r, 0, 0);
    if (s <= w.fore) {
      EXPECT_GE(h, prev - 1e-12) << s;  // the terrace rises to the crest
    }
    steepest = std::max(steepest, std::fabs(h - prev));
    prev = h;
  }
  // Steepest at R₄ — the drop-off's a·u + (1 − a)·u^1.5 has slope
  // (a + 1.5 (1 − a)) × its fall over its width there, a matching the
  // terrace's foot — or on the back-reef slope (the ease's peak, 1.5 × its
  // fall over its width).
  const double fall = rim_edge_depth_m(r) - r.fore_reef_depth_m;
  const double a = 1.5 * (r.fore_reef_depth_m + c.crest_m) / r.fore_reef_m * kDropOffWidthM / fall;
  const double at_edge = (a + 1.5 * (1 - a)) * fall / kDropOffWidthM, back = 1.5 * (c.flat_m - back_m) / w.back;
  EXPECT_LE(steepest, std::max(at_edge, back) + 0.01);
  EXPECT_GE(steepest, std::max(at_edge, back) - 0.02);
  EXPECT_LE(std::atan(at_edge) * 180 / M_PI, 45);  // the drop-off at most ~45° (Bikini: ~25° to 366 m, 30–45° elsewhere)
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
  // Reef flats of hundreds of metres (Johnson & Ortiz: 850 ± 817 m), not a tyre.
  EXPECT_GE(st.reef_flat_width_m, 400);
  // Motu are labelled beach (the green a painter puts on a reef ring).
  int motu_beach = 0;
  for (int y = 0; y < 513; ++y)
    for (int x = 0; x < 513; ++x) motu_beach += f.height_m(y, x) > 0.5f && f.label(y, x) == kBeach;
  EXPECT_GT(motu_beach, 100);
}

// Reefs at their real proportions on the two reef presets at 513² (11.7 m
// cells; docs/REEF.md "Reef proportions" has the 1025² figures): flats of
// ≥ 400 m, no dead-level plane (no 2-cm bin of the −2…+1 m band holds
// more than 6 % of it), and no wall: no cell above −30 m (rim, motu,
// lagoon) steeper than 70° — the old motu slabs and fore reef had 60 m in
// one cell, and fail it.
TEST(Reef, PresetRimsAreWideUnevenAndWithoutWalls) {
  for (const char* name : {"atoll", "barrier-reef"}) {
    const IslandSpec s = preset(name);
    constexpr int kSide = 513;
    const double mpp = s.world_size_m / kSide;
    const IslandFields f = generate(s, side(kSide));
    EXPECT_GE(terrain::reef_stats(f.height_m, mpp).reef_flat_width_m, 400) << name;
    std::vector<int> bins(150, 0);
    int band = 0;
    double steepest = 0;
    for (int y = 1; y + 1 < kSide; ++y)
      for (int x = 1; x + 1 < kSide; ++x) {
        const float h = f.height_m(y, x);
        if (h >= -2.f && h < 1.f) ++bins[std::min(149, int((h + 2.f) / 0.02f))], ++band;
        if (h <= -30.f) continue;
        const double gx = (f.height_m(y, x + 1) - f.height_m(y, x - 1)) / (2 * mpp);
        const double gy = (f.height_m(y + 1, x) - f.height_m(y - 1, x)) / (2 * mpp);
        steepest = std::max(steepest, std::atan(std::hypot(gx, gy)) * 180 / M_PI);
      }
    ASSERT_GT(band, 0) << name;
    EXPECT_LE(double(*std::max_element(bins.begin(), bins.end())) / band, 0.06) << name;
    EXPECT_LE(steepest, 70) << name;
  }
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
  // The crest lies fore_reef_m + half the crest inward of R₄ (canvas units: × 2 / the canvas).
  const RimWidths w = rim_widths_m((o.radii(M_PI)[3] - o.radii(M_PI)[2]) * s.world_size_m / 2, -plan_reef(s, o).windward[0], s.reef);
  const double r_crest = o.radii(M_PI)[3] - (w.fore + 0.5 * w.crest) * 2 / s.world_size_m;
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

// The flank's profile: it leaves the reef at kFlankTopSlope, relaxes as it
// nears the floor (¾ of that slope halfway down) and never passes the span.
TEST(OceanFloor, TheFlankLeavesTheReefAtItsSlopeAndRelaxes) {
  const double span = 1940, eps = 1e-3;
  EXPECT_EQ(terrain::flank_drop_m(0, span), 0);
  EXPECT_NEAR(terrain::flank_drop_m(eps, span) / eps, terrain::kFlankTopSlope, 1e-6);
  const double half = span / terrain::kFlankTopSlope * std::atanh(0.5);  // where it is halfway down
  EXPECT_NEAR(terrain::flank_drop_m(half, span), span / 2, 1e-9);
  const double slope_half = (terrain::flank_drop_m(half + eps, span) - terrain::flank_drop_m(half - eps, span)) / (2 * eps);
  EXPECT_NEAR(slope_half, 0.75 * terrain::kFlankTopSlope, 1e-6);
  EXPECT_LT(terrain::flank_drop_m(1e6, span), span + 1e-9);
  EXPECT_GT(terrain::flank_drop_m(1e6, span), span - 1e-6);
  EXPECT_EQ(terrain::flank_drop_m(100, 0), 0);
}

namespace {

// A 64² atoll of 50 m cells: a rim at -1 m around a -70 m lagoon, the ocean
// falling from -60 m at the rim to -100 m 16 cells out; with a pass, the rim
// has a gap at -70 m joining the lagoon to the ocean below the knee.
cv::Mat1f atoll_64(bool pass) {
  cv::Mat1f h(64, 64, -100.f);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const double r = std::hypot(x - 31.5, y - 31.5);
      if (r < 12) h(y, x) = -70.f;
      else if (r < 16) h(y, x) = (pass && std::abs(y - 31.5) < 2 && x > 31) ? -70.f : -1.f;
      else h(y, x) = float(-60.0 - 40.0 * std::min(1.0, (r - 16) / 16));
    }
  return h;
}

// The steepest step between 4-neighbours that are both in `mask`, m per m.
double steepest_step(const cv::Mat1f& h, const cv::Mat1b& mask, double cell_m) {
  double s = 0;
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      if (x + 1 < h.cols && mask(y, x) && mask(y, x + 1)) s = std::max(s, double(std::abs(h(y, x) - h(y, x + 1))));
      if (y + 1 < h.rows && mask(y, x) && mask(y + 1, x)) s = std::max(s, double(std::abs(h(y, x) - h(y + 1, x))));
    }
  return s / cell_m;
}

}  // namespace

// --ocean-floor-m: the open ocean sinks by the flank's drop at its distance
// from the reef (the Euclidean distance to the nearest cell that is not open
// ocean, here found by brute force, less half a cell to the contour; the
// smoothed one lies within a Gaussian's mean radius, σ √(π/2), of it), never
// below the floor; a lagoon behind its rim keeps its depth even below the
// knee; no step is steeper than the field's own plus the flank's slope.
TEST(OceanFloor, TheOpenOceanSinksWithItsDistanceFromTheReef) {
  const double cell = 50, floor = -2000;
  const cv::Mat1f h = atoll_64(false);
  cv::Mat1f d = h.clone();
  terrain::deepen_flank(d, floor, cell);
  const double span = -100 - floor;  // the ocean's lowest cell, -100 m, to the floor
  for (const cv::Point p : {cv::Point(0, 0), cv::Point(63, 31), cv::Point(31 + 17, 31), cv::Point(5, 40)}) {
    double nearest = 1e9;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x)
        if (!(h(y, x) < terrain::kFlankKneeM)) nearest = std::min(nearest, std::hypot(x - p.x, y - p.y));
    // Within a near σ's mean radius where only the near blur is read (3 σ
    // from the reef), within the far σ's beyond.
    const double near_off = std::sqrt(M_PI / 2) * terrain::kFlankDistanceBlurPx;
    const bool near_only = nearest - 0.5 + near_off < 3 * terrain::kFlankDistanceBlurPx;
    const double off = near_off * (near_only ? 1 : terrain::kFlankFarBlurMinRatio) + 0.01;
    const double deepest = std::max(floor, h(p) - terrain::flank_drop_m((nearest - 0.5 + off) * cell, span));
    const double shallowest = std::max(floor, h(p) - terrain::flank_drop_m(std::max(0.0, nearest - 0.5 - off) * cell, span));
    EXPECT_GE(d(p), deepest - 1e-3) << p;
    EXPECT_LE(d(p), shallowest + 1e-3) << p;
  }
  EXPECT_FLOAT_EQ(d(31, 31), -70.f);      // the lagoon is not the ocean
  EXPECT_FLOAT_EQ(d(31, 31 + 14), -1.f);  // nor the rim
  EXPECT_FLOAT_EQ(d(31, 31 + 16), h(31, 31 + 16));  // at the knee itself: unchanged
  const double one_cell_m = terrain::kFlankTopSlope * cell;
  double lo, hi;
  cv::minMaxLoc(d, &lo, &hi);
  EXPECT_GE(lo, floor);
  EXPECT_LT(lo, -700);  // the corners, ~1.4 km from the rim
  const cv::Mat1b ocean = h < terrain::kFlankKneeM;
  EXPECT_LE(steepest_step(d, ocean, cell),
            steepest_step(h, ocean, cell) + terrain::kFlankTopSlope * terrain::kFlankDistanceSteepest + 1e-4);
  // Outwards along a row the ocean only descends (no counter-slope).
  for (int x = 31 + 17; x + 1 < 64; ++x) EXPECT_LE(d(31, x + 1), d(31, x)) << x;
  cv::Mat1f same = h.clone();
  terrain::deepen_flank(same, -90, cell);  // shallower than the ocean already is: nothing
  EXPECT_EQ(cv::norm(same, h, cv::NORM_INF), 0);
  EXPECT_THROW(terrain::deepen_flank(same, std::nan(""), cell), Error);
  EXPECT_THROW(terrain::deepen_flank(same, -20000, cell), Error);
  // Above the knee there is no flank to continue: refused, not ignored.
  EXPECT_THROW(terrain::deepen_flank(same, -59, cell), Error);
  EXPECT_THROW(terrain::deepen_flank(same, -1, cell), Error);
  EXPECT_THROW(terrain::deepen_flank(same, -2000, 0), Error);
  EXPECT_THROW(terrain::deepen_flank(same, -2000, std::nan("")), Error);
  // An ocean a hair below the knee sinks by its distance, not to the floor
  // asked (the old stretch made that one cell an 11 km needle).
  cv::Mat1f shallow(64, 64, -20.f);
  shallow(0, 0) = -60.00001f;
  terrain::deepen_flank(shallow, -11000, cell);
  EXPECT_GT(shallow(0, 0), -60 - one_cell_m);
  // A canvas that is all ocean has no reef to be near: it sinks by the whole span.
  cv::Mat1f sea(16, 16, -80.f);
  sea(3, 3) = -90.f;
  terrain::deepen_flank(sea, -1000, cell);
  EXPECT_FLOAT_EQ(sea(3, 3), -1000.f);
  EXPECT_FLOAT_EQ(sea(0, 0), -990.f);
}

// At a straight reef the smoothing leaves the distance as it is: the flank
// is continuous at the knee, the first ocean cell half a cell's distance
// from the contour, and then the drop of each distance.
TEST(OceanFloor, AtAStraightReefTheFirstOceanCellSinksByHalfACellsSlope) {
  const double cell = 20, floor = -3000;
  cv::Mat1f h(48, 96, -1.f);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 40; x < h.cols; ++x) h(y, x) = -61.f - float(x - 40) * 0.1f;
  cv::Mat1f d = h.clone();
  terrain::deepen_flank(d, floor, cell);
  double lowest;
  cv::minMaxLoc(h, &lowest);
  const double span = lowest - floor;
  // Within 0.02 cells of distance: the far blur's odd continuation stops a
  // coarse canvas width out, where the Gaussian's tail weighs < 1 %.
  const double tolerance_m = 0.02 * terrain::kFlankTopSlope * cell;
  for (const int x : {40, 41, 50, 80, 95})
    for (const int y : {0, 24, 47})
      EXPECT_NEAR(d(y, x), h(y, x) - terrain::flank_drop_m((x - 40 + 0.5) * cell, span), tolerance_m) << x << "," << y;
  EXPECT_EQ(cv::norm(d.colRange(0, 40), h.colRange(0, 40), cv::NORM_INF), 0);  // the reef does not move
}

// A lagoon the regions mark is kept even where a pass below the knee joins
// it to the ocean; without the regions the same lagoon would be taken for
// the ocean and sunk.
TEST(OceanFloor, ALagoonTheRegionsMarkIsKeptThroughAPass) {
  const double cell = 50;
  const cv::Mat1f h = atoll_64(true);
  cv::Mat1b region(h.size(), uint8_t(kAbyss));
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x)
      if (std::hypot(x - 31.5, y - 31.5) < 12) region(y, x) = kLagoon;
  cv::Mat1f blind = h.clone(), kept = h.clone();
  terrain::deepen_flank(blind, -2000, cell);
  EXPECT_LT(blind(31, 31), -100.f);  // sunk through the pass
  // The regions at half the size (as a sketch is): resized to the heights.
  cv::Mat1b half;
  cv::resize(region, half, {32, 32}, 0, 0, cv::INTER_NEAREST);
  terrain::deepen_flank(kept, -2000, cell, half);
  EXPECT_FLOAT_EQ(kept(31, 31), -70.f);
  EXPECT_FLOAT_EQ(kept(31, 25), -70.f);
  EXPECT_LT(kept(0, 0), -700.f);  // the ocean still sinks
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
