// Rain from the wind (terrain/rain.hpp), the discharge the erosion reads,
// the drainage-organisation measure (terrain/landform.hpp) on shapes whose
// answer is known, and the shield's seeds (procgen).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "reefgen/error.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/spec.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/terrain/drainage.hpp"
#include "reefgen/terrain/erosion.hpp"
#include "reefgen/terrain/flow.hpp"
#include "reefgen/terrain/landform.hpp"
#include "reefgen/terrain/rain.hpp"

using namespace reefgen;

namespace {
// A Gaussian hill of peak_m, σ sigma_px, centred on an n² field.
cv::Mat1f hill(int n, double peak_m, double sigma_px) {
  cv::Mat1f h(n, n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double r2 = (x - n / 2.0) * (x - n / 2.0) + (y - n / 2.0) * (y - n / 2.0);
      h(y, x) = float(peak_m * std::exp(-r2 / (2 * sigma_px * sigma_px)) - 20);
    }
  return h;
}

double mean_in(const cv::Mat1f& m, const cv::Rect& r) { return cv::mean(m(r))[0]; }

// A cone of radius R cells with `azimuths` grooves (depth_m each, Gaussian
// across of σ w = 2.5 cells), on an n² field.
cv::Mat1f grooved_cone(int n, const std::vector<double>& azimuths, const std::vector<double>& depth_m) {
  cv::Mat1f h(n, n);
  const double R = 0.4 * n, w = 2.5;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double dx = x - n / 2.0, dy = y - n / 2.0, r = std::hypot(dx, dy), a = std::atan2(dy, dx);
      double z = 500 * (1 - r / R);
      for (size_t k = 0; k < azimuths.size(); ++k) {
        const double d = std::remainder(a - azimuths[k], 2 * CV_PI);
        const double across = d * r;  // cells: valleys keep their width down the flank
        z -= depth_m[k] * std::clamp((r - 0.05 * R) / (0.25 * R), 0.0, 1.0) * std::exp(-across * across / (2 * w * w));
      }
      h(y, x) = r < R ? float(std::max(z, 1.0)) : -50.f;
    }
  return h;
}
}  // namespace

// Smith & Barstad's linear model: the windward flank gets more than the
// sea's rain, the lee less, the flat sea the background itself.
TEST(Rain, WindwardWetLeewardDry) {
  const int n = 128;
  const double dx = 200;  // m: a 25 km field, a hill of σ 3 km
  const cv::Mat1f h = hill(n, 1500, 15);
  terrain::RainParams p;
  const cv::Mat1f rain = terrain::orographic_rain_mm_yr(h, dx, {1, 0}, p);  // blowing towards +x
  // The flanks 3.2–5.6 km either side of the summit.
  const cv::Rect windward(n / 2 - 28, n / 2 - 5, 12, 10), leeward(n / 2 + 16, n / 2 - 5, 12, 10);
  const double wet = mean_in(rain, windward), dry = mean_in(rain, leeward);
  EXPECT_GT(wet, 1.5 * p.background_mm_yr) << "windward";
  EXPECT_LT(dry, 0.8 * p.background_mm_yr) << "leeward";
  EXPECT_GT(wet, 3 * dry);
  // The same wind the other way: the sides swap.
  const cv::Mat1f back = terrain::orographic_rain_mm_yr(h, dx, {-1, 0}, p);
  EXPECT_GT(mean_in(back, leeward), 3 * mean_in(back, windward));
  // No relief, no orographic rain: the background (the DFT's rounding only).
  const cv::Mat1f sea(n, n, -30.f);
  double lo, hi;
  cv::minMaxLoc(terrain::orographic_rain_mm_yr(sea, dx, {0, 1}, p), &lo, &hi);
  EXPECT_NEAR(lo, p.background_mm_yr, 1e-3 * p.background_mm_yr);
  EXPECT_NEAR(hi, p.background_mm_yr, 1e-3 * p.background_mm_yr);
  // Never below the floor.
  EXPECT_GE(lo, p.floor_share * p.background_mm_yr);
  EXPECT_THROW(terrain::orographic_rain_mm_yr(h, dx, {0, 0}, p), Error);
  EXPECT_THROW(terrain::orographic_rain_mm_yr(h, 0, {1, 0}, p), Error);
}

// The discharge: each cell brings its area times its rain.
TEST(Rain, DischargeIsRainTimesAreaUpstream) {
  cv::Mat1f h(16, 16, -5.f);
  for (int y = 2; y < 14; ++y)
    for (int x = 2; x < 14; ++x) h(y, x) = float(1 + x);  // a plane draining west to the sea
  const cv::Mat1b role = terrain::sea_and_edge_roles(h);
  terrain::FlowGraph g;
  terrain::route_flood(h, role, 10, g);
  std::vector<float> area, wet;
  terrain::accumulate_single(g, role, 100, area);
  const cv::Mat1f rain(h.size(), 2.5f);
  terrain::accumulate_single(g, role, 100, wet, rain.ptr<float>());
  double total = 0, total_wet = 0;
  for (const int i : g.stack) total += area[size_t(i)], total_wet += wet[size_t(i)];
  EXPECT_NEAR(total_wet, 2.5 * total, 1e-4 * total_wet);
  terrain::accumulate_multiple(g, role, 100, 10, 1, area);
  terrain::accumulate_multiple(g, role, 100, 10, 1, wet, rain.ptr<float>());
  for (const int i : g.stack) EXPECT_NEAR(wet[size_t(i)], 2.5 * area[size_t(i)], 1e-3 * wet[size_t(i)]);
}

// Runoff = rain − evapotranspiration, at least kMinRunoffShare of the rain,
// over its mean on the land: ET turns a 2× rain contrast into a 6× runoff
// contrast, and a lee drier than ET keeps its storms' tenth.
TEST(Rain, RunoffIsRainLessEvapotranspiration) {
  const cv::Mat1f h(4, 4, 10.f);
  cv::Mat1f rain(4, 4, 1000.f);
  rain.colRange(2, 4).setTo(2000.f);
  auto left_right = [&](double et) {
    const cv::Mat1f r = terrain::runoff_relative_to_land_mean(rain, h, et);
    return std::pair<double, double>{r(0, 0), r(0, 3)};
  };
  const auto none = left_right(0), some = left_right(800), most = left_right(1500);
  EXPECT_NEAR(none.first, 1000.0 / 1500, 1e-6);
  EXPECT_NEAR(none.second, 2000.0 / 1500, 1e-6);
  EXPECT_NEAR(some.first, 200.0 / 700, 1e-6);  // 200 and 1200 mm/yr run off
  EXPECT_NEAR(some.second, 1200.0 / 700, 1e-6);
  EXPECT_NEAR(most.first, 100.0 / 300, 1e-6);  // the dry side's floor: 10 % of 1000
  EXPECT_NEAR(most.second, 500.0 / 300, 1e-6);
  // No land: the same discharge everywhere.
  const cv::Mat1f sea(4, 4, -10.f);
  EXPECT_EQ(cv::norm(terrain::runoff_relative_to_land_mean(rain, sea, 800), cv::Mat1f(4, 4, 1.f), cv::NORM_INF), 0.0);
}

// rain_erodibility_exponent: at the same discharge weights, the wetter half
// of a flank is cut deeper and the drier half less than with K alone.
TEST(Rain, WetterRockIncisesFaster) {
  cv::Mat1f h0(40, 40, -5.f);
  for (int y = 2; y < 38; ++y)
    for (int x = 2; x < 38; ++x) h0(y, x) = float(2 * x) + 0.01f * float((x * 13 + y * 7) % 11);  // draining west
  cv::Mat1f rain(h0.size(), 0.5f);
  rain.rowRange(20, 40).setTo(1.5f);  // the south half wet
  const cv::Mat1f K(h0.size(), 1e-4f);
  auto worn = [&](double b) {
    terrain::ErosionParams p;
    p.rain_erodibility_exponent = b;
    cv::Mat1f h = h0.clone();
    terrain::erode_level(h, K, 10, 4, 2000, p, terrain::Routing::kFlood, 0, rain);
    double dry = 0, wet = 0;
    for (int y = 2; y < 38; ++y)
      for (int x = 2; x < 38; ++x) (y < 20 ? dry : wet) += double(h0(y, x) - h(y, x));
    return std::pair<double, double>{dry, wet};
  };
  const auto k_alone = worn(0), wet_k = worn(1);
  ASSERT_GT(k_alone.first, 0.0);
  EXPECT_GT(wet_k.second, 1.1 * k_alone.second) << "wet half";
  EXPECT_LT(wet_k.first, 0.9 * k_alone.first) << "dry half";
}

// The measure on cones: equal radial grooves are a comb (one spectral peak,
// equal spacing, no sector stands out); grooves at random azimuths, and
// deep ones on one side only, read as such.
TEST(Landform, TellsACombFromIrregularValleys) {
  const int n = 400;
  std::vector<double> comb_a, comb_d;
  for (int k = 0; k < 24; ++k) comb_a.push_back(2 * CV_PI * k / 24), comb_d.push_back(25);
  const auto comb = terrain::landform_stats(grooved_cone(n, comb_a, comb_d), 10);
  Rng rng(7, 0, "test-grooves");
  std::vector<double> rand_a, rand_d, side_d;
  for (int k = 0; k < 24; ++k) rand_a.push_back(rng.uniform(0, 2 * CV_PI)), rand_d.push_back(rng.uniform(10, 40));
  for (int k = 0; k < 24; ++k) side_d.push_back(std::cos(comb_a[size_t(k)]) > 0 ? 40 : 5);
  const auto irregular = terrain::landform_stats(grooved_cone(n, rand_a, rand_d), 10);
  const auto one_sided = terrain::landform_stats(grooved_cone(n, comb_a, side_d), 10);
  EXPECT_LT(comb.spacing_cv, 0.15) << "24 equal grooves";
  EXPECT_GT(comb.spectrum_peak_ratio, 20);
  EXPECT_LT(comb.sector_cv, 0.1);
  EXPECT_GE(comb.valleys_on_circles, 3 * 22);
  EXPECT_GT(irregular.spacing_cv, 0.5) << "random azimuths";
  EXPECT_LT(irregular.spectrum_peak_ratio, comb.spectrum_peak_ratio / 2);
  EXPECT_GT(one_sided.sector_cv, 0.4) << "deep grooves on one side";
  EXPECT_THROW(terrain::landform_stats(cv::Mat1f(64, 64, -10.f), 10), Error);
  cv::Mat1f bad = grooved_cone(64, comb_a, comb_d);
  bad(3, 3) = std::nanf("");
  EXPECT_THROW(terrain::landform_stats(bad, 10), Error);
}

// The valley depth (closing less heights): a cone's grooves as deep as
// they were cut, a plain cone none; with a wind, the side it comes from
// against the other (grooves 40 m deep east, 12 m west: the east is
// windward for a wind from 90°, leeward for one from 270°).
TEST(Landform, ValleyDepthAndTheWindwardSide) {
  const int n = 400;
  std::vector<double> a, d, side;
  for (int k = 0; k < 24; ++k) {
    a.push_back(2 * CV_PI * k / 24), d.push_back(25);
    side.push_back(std::cos(a.back()) > 0 ? 40 : 12);
  }
  const auto comb = terrain::landform_stats(grooved_cone(n, a, d), 10);
  EXPECT_GT(comb.valley_depth_p90_m, 0.4 * 25);
  EXPECT_LT(comb.valley_depth_p90_m, 1.05 * 25);
  EXPECT_LT(terrain::landform_stats(grooved_cone(n, {}, {}), 10).valley_depth_p90_m, 1.0);
  EXPECT_EQ(comb.windward_depth_ratio, 0);  // no wind given
  const cv::Mat1f lopsided = grooved_cone(n, a, side);
  const double east = terrain::landform_stats(lopsided, 10, 90).windward_depth_ratio;
  const double west = terrain::landform_stats(lopsided, 10, 270).windward_depth_ratio;
  EXPECT_GT(east, 2.0);
  EXPECT_LT(west, 0.5);
  EXPECT_NEAR(east * west, 1.0, 0.05);  // the same two halves, swapped (nearly: the summit's column is leeward both times)
}

// Hack's law on a branching network: a cone's radial channels grow in
// length with area almost linearly (h near 1); a tree of tributaries less.
TEST(Landform, HacksExponentOfAPlainConeIsNearOne) {
  const auto cone = terrain::landform_stats(grooved_cone(300, {}, {}), 10);
  EXPECT_GT(cone.hack_exponent, 0.8);
  EXPECT_LT(cone.hack_exponent, 1.2);
}

// The shield's seed re-rolls the island (the basins' layout, not only the
// grain), and a wind strokes' island is rained on from its windward side.
TEST(Shield, SeedsReRollTheVolcano) {
  procgen::IslandSpec s;
  s.reef.enabled = false;
  procgen::RenderOptions o;
  o.size_px = 257;
  s.noise.seed = 1;
  const cv::Mat1f a = procgen::generate(s, o).height_m;
  s.noise.seed = 2;
  const cv::Mat1f b = procgen::generate(s, o).height_m;
  s.noise.shield = 0;
  s.noise.seed = 1;
  const cv::Mat1f a0 = procgen::generate(s, o).height_m;
  s.noise.seed = 2;
  const cv::Mat1f b0 = procgen::generate(s, o).height_m;
  auto land_correlation = [](const cv::Mat1f& p, const cv::Mat1f& q) {
    std::vector<double> u, v;
    for (int i = 0; i < int(p.total()); ++i)
      if (p(i) > 0 && q(i) > 0) u.push_back(p(i)), v.push_back(q(i));
    const cv::Mat mu(u), mv(v);
    cv::Scalar m1, s1, m2, s2;
    cv::meanStdDev(mu, m1, s1);
    cv::meanStdDev(mv, m2, s2);
    return cv::mean((mu - m1[0]).mul(mv - m2[0]))[0] / (s1[0] * s2[0]);
  };
  const double with = land_correlation(a, b), without = land_correlation(a0, b0);
  EXPECT_LT(with, without - 0.03) << "shield on: " << with << ", off: " << without;
  EXPECT_LT(with, 0.92);
}

// The trunk grid (docs/EROSION.md "Trunk basins"): eroded first, a few large
// basins capture the base grid's valleys, where without it each valley
// drained to the sea on its own at one spacing. Measured at 513² on the
// default spec, seed 1 (trunk off → on): valleys per coastal basin, the
// angular spectrum's peak and the spacing CV printed on failure.
TEST(Trunk, BasinsCaptureTheBaseGridsValleys) {
  procgen::IslandSpec s;
  s.reef.enabled = false;
  s.noise.seed = 1;
  procgen::RenderOptions o;
  o.size_px = 513;
  const double mpp = s.world_size_m / o.size_px;
  const auto on = terrain::landform_stats(procgen::generate(s, o).height_m, mpp);
  s.erosion.trunk_px = 0;
  const auto off = terrain::landform_stats(procgen::generate(s, o).height_m, mpp);
  const std::string both = "off: " + std::to_string(off.valleys_per_basin) + " valleys/basin, spectrum " +
                           std::to_string(off.spectrum_peak_ratio) + ", spacing CV " + std::to_string(off.spacing_cv) +
                           "; on: " + std::to_string(on.valleys_per_basin) + ", " + std::to_string(on.spectrum_peak_ratio) +
                           ", " + std::to_string(on.spacing_cv);
  std::printf("%s\n", both.c_str());
  EXPECT_GT(on.valleys_per_basin, off.valleys_per_basin) << both;
  EXPECT_LT(on.spectrum_peak_ratio, off.spectrum_peak_ratio) << both;
  EXPECT_GT(on.spacing_cv, off.spacing_cv) << both;
}

// What the trunk passes on: the share of each cell's height it kept, in
// [kTrunkMinKeptShare, 1] on the land, carried over the sea's first rings
// (the mean of the known neighbours) and 1 beyond them.
TEST(Trunk, KeptShareIsBoundedAndCarriedOverTheSea) {
  const int n = 256;
  cv::Mat1f h(n, n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) h(y, x) = float(600 * (1 - std::hypot(x - n / 2 + 0.5, y - n / 2 + 0.5) / (0.3 * n)));
  const cv::Mat1f rho(n, n, 0.3f);
  terrain::ErosionParams p;
  const int T = 64;
  const cv::Mat1f kept = terrain::trunk_kept_share(h, rho, 6000, 1, p, T, 1e6);
  ASSERT_EQ(kept.rows, T);
  double lowest = 1;
  for (int y = 0; y < T; ++y)
    for (int x = 0; x < T; ++x) {
      EXPECT_GE(kept(y, x), 0.35f - 1e-6f);
      EXPECT_LE(kept(y, x), 1.f);
      lowest = std::min(lowest, double(kept(y, x)));
    }
  EXPECT_LT(lowest, 0.9) << "a million years of erosion lowered nothing";
  EXPECT_EQ(kept(0, 0), 1.f) << "far out at sea";
  EXPECT_THROW(terrain::trunk_kept_share(cv::Mat1f(), rho, 6000, 1, p, T, 1e6), Error);
}
