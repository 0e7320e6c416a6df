// The pieces of terrain/ one at a time, against values worked out by hand
// from their equations (docs/EROSION.md): the flow graph, drainage area by
// one and by several flow directions, the implicit stream-power update and
// hillslope diffusion.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/terrain/drainage.hpp"
#include "reefgen/terrain/eroders.hpp"
#include "reefgen/terrain/erosion.hpp"
#include "reefgen/terrain/flat_channels.hpp"
#include "reefgen/terrain/flow.hpp"
#include "reefgen/terrain/layers.hpp"
#include "reefgen/terrain/world_layers.hpp"
#include "reefgen/cpu.hpp"
#include "reefgen/error.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/random_spec.hpp"
#include "test_util.hpp"

using namespace reefgen;
using namespace reefgen::terrain;

namespace {

// A 5×4 plane rising 1 m per row away from row 0; rows 1–2, columns 1–3 are
// land (active), the edge is an outlet. Cell size 1 m.
cv::Mat1f plane() {
  cv::Mat1f h(4, 5);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 5; ++x) h(y, x) = float(y) + 1.f;
  return h;
}

}  // namespace

TEST(FlowGraph, StackPutsEveryReceiverBeforeItsDonors) {
  const cv::Mat1f h = plane();
  const cv::Mat1b role = sea_and_edge_roles(h);
  for (const bool flood : {true, false}) {
    FlowGraph g;
    if (flood) {
      route_flood(h, role, 1.0, g);
    } else {
      route_stack(h, role, 1.0, 0, g);
    }
    ASSERT_EQ(g.stack.size(), 6u);
    std::vector<int> pos(20, -1);
    for (size_t k = 0; k < g.stack.size(); ++k) pos[size_t(g.stack[k])] = int(k);
    for (const int i : g.stack) {
      // Steepest descent on a plane tilted in y: straight down the rows.
      EXPECT_EQ(g.receiver[size_t(i)], i - 5) << "cell " << i;
      EXPECT_FLOAT_EQ(g.inv_length[size_t(i)], 1.f);
      const int r = g.receiver[size_t(i)];
      if (role(r / 5, r % 5) == kActive) {
        EXPECT_LT(pos[size_t(r)], pos[size_t(i)]);
      }
    }
  }
}

TEST(Drainage, SingleDirectionSumsTheDonors) {
  const cv::Mat1f h = plane();
  const cv::Mat1b role = sea_and_edge_roles(h);
  FlowGraph g;
  route_stack(h, role, 1.0, 0, g);
  std::vector<float> area;
  accumulate_single(g, role, 4.f, area);
  for (int x = 1; x <= 3; ++x) {
    EXPECT_FLOAT_EQ(area[size_t(2 * 5 + x)], 4.f);  // the top row drains only itself
    EXPECT_FLOAT_EQ(area[size_t(1 * 5 + x)], 8.f);  // itself and the cell above
  }
}

TEST(Drainage, MultipleDirectionsShareBySlope) {
  // Quinn's p = 1 on the plane: a row-2 cell sends 1/(1+√2) of its area
  // straight down and (1/√2)/(1+√2) down each diagonal (slope s/√2). The
  // middle cell of row 1 gets all three shares: a + a = 2a; a side cell
  // gets its own straight share and one diagonal: a(1 + (1 + 1/√2)/(1 + √2)).
  const cv::Mat1f h = plane();
  const cv::Mat1b role = sea_and_edge_roles(h);
  FlowGraph g;
  route_flood(h, role, 1.0, g);
  std::vector<float> area;
  accumulate_multiple(g, role, 1.f, 1.0, 1.f, area);
  const double r2 = std::sqrt(2.0);
  EXPECT_NEAR(area[size_t(5 + 2)], 2.0, 1e-6);
  EXPECT_NEAR(area[size_t(5 + 1)], 1.0 + (1.0 + 1.0 / r2) / (1.0 + r2), 1e-6);
  EXPECT_NEAR(area[size_t(5 + 3)], area[size_t(5 + 1)], 1e-6);
  // A large exponent tends to the single steepest direction.
  accumulate_multiple(g, role, 1.f, 1.0, 40.f, area);
  EXPECT_NEAR(area[size_t(5 + 2)], 2.0, 1e-5);
  EXPECT_NEAR(area[size_t(5 + 1)], 2.0, 1e-5);
}

TEST(Eroders, StreamPowerIsTheImplicitUpdate) {
  // One land cell (2, 1) draining to the sea at (2, 0), 0 m:
  // F = K Δt A^m / L = 1e-3 · 10 · 4^0.5 / 1 = 0.02, z ← (102 + 0.02 · 0) / 1.02 = 100.
  cv::Mat1f h(3, 5, -10.f);
  h(1, 2) = 102.f;
  cv::Mat1f z = h.clone();
  z.setTo(0.f, h <= 0);
  const cv::Mat1b role = sea_and_edge_roles(h);
  FlowGraph g;
  route_stack(z, role, 1.0, 0, g);
  ASSERT_EQ(g.stack.size(), 1u);
  const std::vector<float> area(15, 4.f);
  erode_stream_power(z, cv::Mat1f(3, 5, 1e-3f), g, area, 10.0, 0.5);
  EXPECT_NEAR(z(1, 2), 100.f, 1e-4f);
  EXPECT_EQ(z(0, 2), 0.f);  // the base level does not move
}

TEST(Eroders, AboveTheChannelHeadNothingIncises) {
  // The cell of StreamPowerIsTheImplicitUpdate drains 4 m²: with a channel
  // head at 5 m² it is hillslope and keeps its height; at 4 m² it incises.
  cv::Mat1f h(3, 5, -10.f);
  h(1, 2) = 102.f;
  cv::Mat1f z = h.clone();
  z.setTo(0.f, h <= 0);
  const cv::Mat1b role = sea_and_edge_roles(h);
  FlowGraph g;
  route_stack(z, role, 1.0, 0, g);
  const std::vector<float> area(15, 4.f);
  cv::Mat1f above = z.clone();
  erode_stream_power(above, cv::Mat1f(3, 5, 1e-3f), g, area, 10.0, 0.5, 5.0);
  EXPECT_EQ(above(1, 2), 102.f);
  erode_stream_power(z, cv::Mat1f(3, 5, 1e-3f), g, area, 10.0, 0.5, 4.0);
  EXPECT_NEAR(z(1, 2), 100.f, 1e-4f);
}

TEST(Eroders, DiffusionSpreadsASpikeBy2Dt) {
  // ∂h/∂t = D∇²h spreads a point of height to a Gaussian of variance 2 D Δt
  // per axis: D = 2 m²/yr, Δt = 4 yr, 1 m cells → σ² = 16 cells².
  const double sigma = hillslope_sigma_px(2.0, 4.0, 1.0);
  EXPECT_NEAR(sigma * sigma, 16.0, 1e-9);
  cv::Mat1f h(81, 81, 1.f);
  h(40, 40) = 1001.f;
  const cv::Mat1b role = sea_and_edge_roles(h);
  diffuse_hillslope(h, role, cv::Rect(0, 0, 81, 81), sigma);
  double mass = 0, var = 0;
  for (int y = 1; y < 80; ++y)
    for (int x = 1; x < 80; ++x) {
      const double m = h(y, x) - 1.0;
      mass += m;
      var += m * (x - 40) * (x - 40);
    }
  EXPECT_NEAR(mass, 1000.0, 1.0);  // mass kept
  EXPECT_NEAR(var / mass, 16.0, 0.5);
  EXPECT_EQ(h(0, 0), 1.f);  // an outlet (the canvas edge) is not written
}

// Creep between channels (eroders.hpp): far from any channel it is the
// hillslope diffusion's blur, cell for cell; a channel (drainage area past
// A_c) moves far less than the hillslopes beside it; outlets are not written.
TEST(Eroders, CreepRoundsHillslopesAndSparesChannels) {
  cv::Mat1f h(64, 64);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x)
      h(y, x) = 50.f + 0.5f * float(x) + 2.f * std::sin(1.6f * float(x)) * std::cos(1.6f * float(y)) -
                (y == 32 ? 6.f : 0.f);  // a channel along row 32
  const cv::Mat1b role = sea_and_edge_roles(h);
  const cv::Rect all(0, 0, 64, 64);
  const float a_c = 1e4f;
  // No channel anywhere: the same as the hillslope diffusion away from the
  // canvas edge (whose outlets pull the share below 1 within a few cells).
  cv::Mat1f creep = h.clone(), blur = h.clone();
  creep_between_channels(creep, role, all, std::vector<float>(h.total(), 0.f), a_c, 1.5);
  diffuse_hillslope(blur, role, all, 1.5);
  EXPECT_LT(cv::norm(creep(cv::Rect(12, 12, 40, 40)), blur(cv::Rect(12, 12, 40, 40)), cv::NORM_INF), 1e-4);
  EXPECT_EQ(creep(0, 10), h(0, 10));
  // The channel drains 1 km²: its row keeps most of its depth.
  std::vector<float> area(h.total(), 100.f);
  for (int x = 0; x < 64; ++x) area[size_t(32 * 64 + x)] = 1e6f;
  cv::Mat1f z = h.clone();
  creep_between_channels(z, role, all, area, a_c, 1.5);
  double moved_channel = 0, moved_slope = 0;
  for (int x = 8; x < 56; ++x) {
    moved_channel += std::abs(z(32, x) - h(32, x));
    moved_slope += std::abs(z(16, x) - h(16, x));
  }
  EXPECT_LT(moved_channel, 0.5 * std::abs(blur(32, 20) - h(32, 20)) * 48) << "the channel filled like a hillslope";
  EXPECT_GT(moved_slope, 0.5 * 48) << "the hillslope's 2 m bumps did not round off";
  double depth = 0;
  for (int x = 8; x < 56; ++x) depth += 0.5 * (z(31, x) + z(33, x)) - z(32, x);
  EXPECT_GT(depth / 48, 3.0) << "the channel's depth below its banks";
}

TEST(Erosion, LevelIsGoldenOnACone) {
  // erode_level = route + accumulate + stream power + diffusion, step after
  // step. Golden sums pinned when the monolith was split into those pieces
  // (its outputs were byte-identical before and after; docs/EROSION.md).
  for (const Routing routing : {Routing::kFlood, Routing::kStack}) {
    cv::Mat1f h(64, 64);
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        const double r = std::hypot(x - 31.5, y - 31.5) / 20.0;
        h(y, x) = float(r < 1 ? 300 * (1 - r) + 7 * std::sin(x * 0.9) * std::cos(y * 1.3) * (1 - r) : -40);
      }
    ErosionParams p;
    erode_level(h, cv::Mat1f(64, 64, 2e-7f), 50.0, 4, 1e5, p, routing);
    double land_m = 0, peak_m = 0;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x)
        if (h(y, x) > 0) land_m += h(y, x), peak_m = std::max(peak_m, double(h(y, x)));
    // Uneroded: 125 600 m·cells of land, 300 m peak.
    if (routing == Routing::kFlood) {
      EXPECT_NEAR(land_m, 109124.027, 0.05);
      EXPECT_NEAR(peak_m, 287.4744, 1e-3);
    } else {
      EXPECT_NEAR(land_m, 112831.394, 0.05);
      EXPECT_NEAR(peak_m, 287.4390, 1e-3);
    }
  }
}

// ---- Layers (terrain/layers.hpp, docs/LAYERS.md) ----

namespace {
reefgen::procgen::IslandFields eroded_island(int W) {
  procgen::IslandSpec spec = procgen::random_spec(5, 2);
  spec.subsidence = 0.1;
  procgen::RenderOptions ro;
  ro.size_px = W;
  ro.keep_uneroded = true;
  return procgen::generate(spec, ro);
}
}  // namespace

// Ground the finishing raised is a deposit only where it is fill: a cone
// whose summit and flanks were raised 30 m (as the amplification raises
// relief) has no deposit there, while a crater filled 8 m deep (flat, as a
// basin drained by filling) is deposit, 8 m.
TEST(Layers, DepositIsFillNotRaisedRelief) {
  const int W = 96;
  const double dx = 20;
  cv::Mat1f before(W, W), h(W, W);
  for (int y = 0; y < W; ++y)
    for (int x = 0; x < W; ++x) {
      const double r = std::hypot(x - 47.5, y - 47.5) * dx;
      const double cone = 300 - 0.4 * r;  // 22° flanks down to the sea
      before(y, x) = float(cone);
      h(y, x) = float(cone + 30 * std::max(0.0, 1 - r / 400));  // the summit raised 30 m, fading out by 400 m
    }
  // A crater on the south flank, filled flat at 100 m: its floor 8 m above
  // where it was.
  for (int y = 68; y < 76; ++y)
    for (int x = 44; x < 52; ++x) h(y, x) = 100.f, before(y, x) = 92.f;
  const Layers L = compute_layers(h, before, cv::Mat1b(), dx);
  double summit = 0;
  for (int y = 40; y < 56; ++y)
    for (int x = 40; x < 56; ++x) summit = std::max(summit, double(L.deposit_m(y, x)));
  EXPECT_LT(summit, 1.0) << "raised relief on the summit is no sediment";
  EXPECT_GE(L.deposit_m(72, 48), 7.9f) << "the filled crater is";
}

TEST(Layers, WeightsSumTo255AtEveryPixelAndMassIsKept) {
  const auto f = eroded_island(160);
  ASSERT_FALSE(f.uneroded_m.empty());
  const double dx = 6000.0 / 160;
  const Layers L = compute_layers(f.height_m, f.uneroded_m, f.label, dx);
  const auto splat = splat_maps(L);
  for (int y = 0; y < 160; ++y)
    for (int x = 0; x < 160; ++x) {
      int sum = 0;
      float wsum = 0;
      for (int m = 0; m < kNumMaterials; ++m) {
        sum += splat[size_t(m / 4)](y, x)[m % 4];
        wsum += L.weight[size_t(m)](y, x);
        ASSERT_GE(L.weight[size_t(m)](y, x), 0.f);
      }
      ASSERT_EQ(sum, 255) << y << "," << x;
      ASSERT_NEAR(wsum, 1.f, 1e-5f);
    }
  // The deposit is worn material that settled: never more than was worn.
  EXPECT_GT(cv::sum(L.wear_m)[0], 0.0);
  EXPECT_GT(cv::sum(L.deposit_m)[0], 0.0);
  EXPECT_LE(cv::sum(L.deposit_m)[0], cv::sum(L.wear_m)[0]);
  // The flow layer is zero at sea and at least one cell's area on land.
  for (int y = 0; y < 160; ++y)
    for (int x = 0; x < 160; ++x) {
      if (f.height_m(y, x) <= 0) {
        ASSERT_EQ(L.flow_area_m2(y, x), 0.f);
      } else if (x > 0 && y > 0 && x < 159 && y < 159) {
        ASSERT_GE(L.flow_area_m2(y, x), float(dx * dx) * 0.999f);
      }
    }
}

TEST(Layers, MaterialsFollowTheirRules) {
  // West half: a 60° cliff rising from the sea to the east, then a 5° plain;
  // east of the island the abyss. Regions from the heights.
  const int W = 200;
  const double dx = 2.0;
  cv::Mat1f h(W, W);
  for (int y = 0; y < W; ++y)
    for (int x = 0; x < W; ++x) {
      const double d = x * dx;  // metres from the west edge
      h(y, x) = float(d < 100 ? -60 + (d - 0) * 0.05 : d < 200 ? -55 + (d - 100) * std::tan(60 * M_PI / 180) : 118 + (d - 200) * 0.087);
    }
  const Layers L = compute_layers(h, cv::Mat1f(), cv::Mat1b(), dx);
  EXPECT_GT(L.weight[kDeepSeaFloor](100, 10), 0.99f);   // 60 m deep
  EXPECT_GT(L.weight[kRockCliff](100, 90), 0.99f);      // on the 60° face, above the sea
  EXPECT_GT(L.weight[kVegetation](100, 160), 0.9f);     // the 5° plain, high and dry
  EXPECT_NEAR(L.slope_deg(100, 90), 60.f, 0.5f);
  EXPECT_NEAR(L.slope_deg(100, 160), float(std::atan(0.087) * 180 / M_PI), 0.05f);
  // Normals: the face rises to the east, so it leans west (x < 0), unit length.
  const cv::Vec3f n = L.normal(100, 90);
  EXPECT_LT(n[0], -0.8f);
  EXPECT_NEAR(n[1], 0.f, 1e-5f);
  EXPECT_NEAR(cv::norm(n), 1.0, 1e-5);
}

TEST(Layers, NormalsReadNorthUpwards) {
  // Heights rising towards row 0 (north): the normal leans south (y < 0).
  cv::Mat1f h(32, 32);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) h(y, x) = float(100 - 2 * y);
  const Layers L = compute_layers(h, cv::Mat1f(), cv::Mat1b(), 1.0);
  EXPECT_LT(L.normal(16, 16)[1], -0.8f);
  EXPECT_NEAR(L.normal(16, 16)[0], 0.f, 1e-6f);
}

namespace {
// Every map of `a` equals the same rectangle of `b`, bit for bit.
::testing::AssertionResult same_layers(const Layers& a, const Layers& b, const cv::Rect& r) {
  auto same = [&](const cv::Mat& x, const cv::Mat& y, const char* what) -> bool {
    const cv::Mat yr = y(r);
    for (int row = 0; row < x.rows; ++row)
      if (std::memcmp(x.ptr(row), yr.ptr(row), x.cols * x.elemSize()) != 0) {
        std::fprintf(stderr, "%s differs in row %d of tile (%d,%d)\n", what, row, r.x, r.y);
        return false;
      }
    return true;
  };
  bool ok = same(a.flow_area_m2, b.flow_area_m2, "flow") && same(a.slope_deg, b.slope_deg, "slope") &&
            same(a.wear_m, b.wear_m, "wear") && same(a.deposit_m, b.deposit_m, "deposit") &&
            same(a.normal, b.normal, "normal");
  for (int m = 0; m < kNumMaterials && ok; ++m) ok = same(a.weight[size_t(m)], b.weight[size_t(m)], material_name(m));
  return ok ? ::testing::AssertionSuccess() : ::testing::AssertionFailure() << "tile " << r;
}
}  // namespace

// A world's layers, tile by tile (terrain/world_layers.hpp): any tiling gives
// the same bytes as one tile over the whole field, whatever the threads; the
// inputs may come at another resolution; and they agree with the whole-field
// layers (compute_layers) on what matters to a texture artist.
TEST(WorldLayers, AnyTilingGivesTheSameBytesAndFollowsTheWholeField) {
  const int W = 320;
  const auto isl = eroded_island(W);
  const double dx = 6000.0 / W;
  // The uneroded heights and the regions at half the resolution, as a world
  // has them at the model's scale.
  cv::Mat1f before;
  cv::Mat1b region;
  cv::resize(isl.uneroded_m, before, cv::Size(W / 2, W / 2), 0, 0, cv::INTER_AREA);
  cv::resize(isl.label, region, cv::Size(W / 2, W / 2), 0, 0, cv::INTER_NEAREST);
  const WorldLayerField f = world_layer_field(isl.height_m, before, region, dx);
  ASSERT_EQ(f.flow_area_m2.cols, (W + kWorldLayerCoarsening - 1) / kWorldLayerCoarsening);
  const cv::Rect all(0, 0, W, W);
  const Layers whole = world_layers_tile(isl.height_m, f, all);
  EXPECT_TRUE(same_layers(world_layers_tile(isl.height_m, f, all, {}, 2), whole, all));
  const int cuts[] = {0, 97, 211, W};
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) {
      const cv::Rect r(cuts[i], cuts[j], cuts[i + 1] - cuts[i], cuts[j + 1] - cuts[j]);
      EXPECT_TRUE(same_layers(world_layers_tile(isl.height_m, f, r), whole, r));
    }
  // Weights sum to one; the sea drains nothing.
  for (int y = 0; y < W; ++y)
    for (int x = 0; x < W; ++x) {
      float s = 0;
      for (const auto& w : whole.weight) s += w(y, x);
      ASSERT_NEAR(s, 1.f, 1e-5f);
      if (isl.height_m(y, x) <= 0) {
        ASSERT_EQ(whole.flow_area_m2(y, x), 0.f);
      }
    }
  // Against the whole field's layers at full resolution: the same material
  // leads on most pixels, and where the full-resolution drainage carries a
  // river, the coarse copy's does too.
  const Layers ref = compute_layers(isl.height_m, isl.uneroded_m, isl.label, dx);
  int same_lead = 0, rivers = 0, rivers_kept = 0;
  for (int y = 0; y < W; ++y)
    for (int x = 0; x < W; ++x) {
      int a = 0, b = 0;
      for (int m = 1; m < kNumMaterials; ++m) {
        if (whole.weight[size_t(m)](y, x) > whole.weight[size_t(a)](y, x)) a = m;
        if (ref.weight[size_t(m)](y, x) > ref.weight[size_t(b)](y, x)) b = m;
      }
      same_lead += a == b;
      if (ref.flow_area_m2(y, x) > LayerParams{}.river_area_m2) {
        ++rivers;
        // Within two pixels of this one, the coarse copy carries at least a fifth of it.
        float best = 0;
        for (int v = std::max(0, y - 2); v <= std::min(W - 1, y + 2); ++v)
          for (int u = std::max(0, x - 2); u <= std::min(W - 1, x + 2); ++u) best = std::max(best, whole.flow_area_m2(v, u));
        rivers_kept += best >= 0.2f * ref.flow_area_m2(y, x);
      }
    }
  std::printf("lead material agrees on %.1f %% of pixels; rivers kept %d of %d\n", 100.0 * same_lead / (W * W),
              rivers_kept, rivers);
  EXPECT_GE(same_lead, 0.85 * W * W);
  ASSERT_GT(rivers, 50);
  EXPECT_GE(rivers_kept, 0.8 * rivers);
  EXPECT_THROW(world_layers_tile(isl.height_m, f, cv::Rect(W - 10, 0, 20, 10)), reefgen::Error);
}

TEST(Layers, RulesRoundTripAndRefuseBadValues) {
  LayerParams p;
  p.cliff_deg = 50;
  nlohmann::json j;
  to_json(j, p);
  EXPECT_EQ(layer_params_from_json(j, "r.json").cliff_deg, 50);
  EXPECT_THROW(layer_params_from_json({{"cliff_deg", 95}}, "r.json"), reefgen::Error);
  EXPECT_THROW(layer_params_from_json({{"clif_deg", 30}}, "r.json"), reefgen::Error);
  EXPECT_THROW(compute_layers(cv::Mat1f(4, 4, NAN), cv::Mat1f(), cv::Mat1b(), 1.0), reefgen::Error);
}

namespace {

// route_stack's receivers written the plain way (the code before the
// dispatched row scan): the reference every vector path must equal bit for
// bit.
std::vector<int> reference_receivers(const cv::Mat1f& h, const cv::Mat1b& role, double mpp, uint64_t salt) {
  const int dx[8] = {1, -1, 0, 0, 1, 1, -1, -1}, dy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  const float ax = float(1.0 / mpp), dg = float(1.0 / (mpp * std::sqrt(2.0)));
  const float inv[8] = {ax, ax, ax, ax, dg, dg, dg, dg};
  const int W = h.cols, H = h.rows;
  std::vector<int> recv(size_t(W * H));
  for (int i = 0; i < W * H; ++i) {
    recv[size_t(i)] = i;
    if (role(i / W, i % W) != kActive) continue;
    const int x = i % W, y = i / W;
    float best = 0.f, w[8], sum = 0.f;
    for (int k = 0; k < 8; ++k) {
      w[k] = 0.f;
      const int nx = x + dx[k], ny = y + dy[k];
      if (nx < 0 || ny < 0 || nx >= W || ny >= H || role(ny, nx) == kIgnore) continue;
      const float sl = (h(y, x) - h(ny, nx)) * inv[k];
      if (sl > 0.f) sum += (w[k] = sl * sl);
      if (sl > best) best = sl, recv[size_t(i)] = ny * W + nx;
    }
    if (salt == 0 || sum <= 0.f) continue;
    const float u = float(mix64(salt ^ mix64(uint64_t(i))) >> 40) * (1.f / 16777216.f) * sum;
    float c = 0.f;
    for (int k = 0; k < 8; ++k) {
      if (w[k] <= 0.f) continue;
      c += w[k];
      recv[size_t(i)] = (y + dy[k]) * W + x + dx[k];
      if (u < c) break;
    }
  }
  return recv;
}

}  // namespace

// The row scan runs on the CPU's vector path (docs/BENCHMARKS.md, "Vector
// paths"); REEFGEN_CPU_PATH forces each smaller one. Every path must give the
// reference's receivers exactly, ties (heights on a 0.5 m grid) and ignored
// cells included. A path the CPU lacks is capped to the widest it has, so on
// an AVX2-only machine "avx512" checks avx2 again (said in the log).
TEST(FlowGraph, EveryVectorPathGivesTheReferenceReceivers) {
  cv::Mat1f h(53, 67);
  cv::Mat1b role(h.size());
  cv::RNG rng(7);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      h(y, x) = std::round(float(rng.uniform(0.0, 40.0)) * 2.f) / 2.f;
      const int r = rng.uniform(0, 10);
      role(y, x) = r == 0 ? kIgnore : r == 1 ? kOutlet : kActive;
    }
  for (const char* path : {"sse2", "avx2", "avx512"}) {
    const test::ScopedEnv force("REEFGEN_CPU_PATH", path);
    std::printf("REEFGEN_CPU_PATH=%s runs the %s path\n", path, to_string(cpu_path()));
    for (const uint64_t salt : {uint64_t(0), uint64_t(0x5eed)}) {
      for (const double mpp : {1.0, 23.4375}) {
        FlowGraph g;
        route_stack(h, role, mpp, salt, g);
        EXPECT_EQ(g.receiver, reference_receivers(h, role, mpp, salt)) << path << " salt " << salt << " mpp " << mpp;
      }
    }
  }
}

// Straight flat channels, on a cone whose every cell falls 2 %: a flat,
// straight 40×4 px strip (its 38×2 interior is flat by central differences)
// counts once; a flat strip that bends (an L of two 22 px legs), a round
// flat pond 30 px across, a flat strip 24 px long and the flat sea count
// nothing; a flat spit into the sea counts apart.
TEST(FlatChannels, CountsStraightFlatStripsOnLandOnly) {
  const int n = 256;
  const double mpp = 10;
  cv::Mat1f h(n, n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) h(y, x) = float(20 - 0.02 * mpp * std::hypot(x - 128.0, y - 128.0));
  h.setTo(-5, h <= 0);
  const auto none = flat_channel_stats(h, mpp);
  EXPECT_EQ(none.channels, 0);
  EXPECT_NEAR(none.land_km2, M_PI * 100 * 100 * mpp * mpp * 1e-6, 0.01);  // the cone meets the sea 100 px out
  h(cv::Rect(60, 100, 40, 4)).setTo(12);
  const auto one = flat_channel_stats(h, mpp);
  EXPECT_EQ(one.channels, 1);
  EXPECT_NEAR(one.longest_px, 38, 1e-3);
  EXPECT_NEAR(one.per_1000_km2, 1000.0 / one.land_km2, 1e-9);
  h(cv::Rect(150, 60, 24, 4)).setTo(5);
  h(cv::Rect(170, 60, 4, 24)).setTo(5);
  cv::circle(h, {170, 170}, 15, cv::Scalar(8), cv::FILLED);
  h(cv::Rect(60, 170, 26, 4)).setTo(6);
  EXPECT_EQ(flat_channel_stats(h, mpp).channels, 1);
  // The same strip turned 45°: still one straight channel.
  for (int i = 0; i < 40; ++i) h(cv::Rect(100 + i, 50 + i, 4, 1)).setTo(4);
  EXPECT_EQ(flat_channel_stats(h, mpp).channels, 2);
  // A flat spit running out into the sea is counted apart, as a coastal strip.
  h(cv::Rect(200, 126, 40, 4)).setTo(0.5f);
  const auto spit = flat_channel_stats(h, mpp);
  EXPECT_EQ(spit.channels, 2);
  EXPECT_EQ(spit.coastal, 1);
  EXPECT_EQ(one.coastal, 0);
  EXPECT_THROW(flat_channel_stats(cv::Mat1f(), mpp), reefgen::Error);
  EXPECT_THROW(flat_channel_stats(h, 0), reefgen::Error);
}
