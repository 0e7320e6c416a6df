// The painted reef finished from its zones (infer/reef_finish.hpp): a
// blurred model answer of an atoll (a rim at -6 m, a lagoon at -25 m, a
// pass, five islets) gets its crest at sea level, its motu above it, and
// nothing else moves.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/infer/reef_finish.hpp"
#include "reefgen/interrupt.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/procgen/spec.hpp"
#include "reefgen/rows.hpp"
#include "reefgen/terrain/pits.hpp"

using namespace reefgen;
using namespace reefgen::infer;

namespace {

constexpr int kSide = 128;
constexpr double kWorldM = kCanvasWorldSizeM * kSide / kModelSidePx;  // model cells of 23.4 m
constexpr double kRimOutPx = 44, kRimInPx = 36, kPassHalfWidthRad = 0.12;

struct PaintedAtoll {
  cv::Mat1b label;
  cv::Mat1f model_m;  // what a blurring model answers
  std::vector<cv::Point2d> motu;
};

double radius_px(int x, int y) { return std::hypot(x - (kSide - 1) / 2.0, y - (kSide - 1) / 2.0); }

PaintedAtoll painted_atoll() {
  PaintedAtoll a{cv::Mat1b(kSide, kSide, uint8_t(kAbyss)), cv::Mat1f(kSide, kSide, -80.f), {}};
  for (int y = 0; y < kSide; ++y)
    for (int x = 0; x < kSide; ++x) {
      const double r = radius_px(x, y), th = std::atan2(y - (kSide - 1) / 2.0, x - (kSide - 1) / 2.0);
      if (r < kRimInPx) a.label(y, x) = kLagoon, a.model_m(y, x) = -25.f;
      else if (r < kRimOutPx) a.label(y, x) = kReef, a.model_m(y, x) = -6.f;
      // A pass painted as lagoon through the rim, due east.
      if (r < kRimOutPx + 1 && std::abs(th) < kPassHalfWidthRad) a.label(y, x) = kLagoon, a.model_m(y, x) = -18.f;
    }
  for (int k = 0; k < 5; ++k) {
    const double th = 0.6 + 2 * M_PI * k / 5.5, r = (kRimInPx + kRimOutPx) / 2;
    const cv::Point2d c((kSide - 1) / 2.0 + r * std::cos(th), (kSide - 1) / 2.0 + r * std::sin(th));
    cv::circle(a.label, cv::Point(int(std::lround(c.x)), int(std::lround(c.y))), 2, cv::Scalar(kBeach), -1);
    a.motu.push_back(c);
  }
  cv::GaussianBlur(a.model_m, a.model_m, cv::Size(0, 0), 1.5);
  return a;
}

cv::Mat1f finished(const PaintedAtoll& a, int side, uint64_t seed = 1) {
  cv::Mat1f h;
  cv::resize(a.model_m, h, cv::Size(side, side), 0, 0, cv::INTER_CUBIC);
  finish_painted_reef(h, a.label, kWorldM, seed);
  return h;
}

}  // namespace

// The crest at the reef's top along rays that do not cross the pass; the
// lagoon, the pass and the open sea untouched.
TEST(PaintedReef, CrestAtSeaLevelPassAndLagoonUntouched) {
  const PaintedAtoll a = painted_atoll();
  const int N = 4 * kSide;
  cv::Mat1f before;
  cv::resize(a.model_m, before, cv::Size(N, N), 0, 0, cv::INTER_CUBIC);
  const cv::Mat1f h = finished(a, N);
  const double c = (N - 1) / 2.0, scale = double(N) / kSide;
  int rays = 0, at_sea = 0;
  for (int i = 0; i < 72; ++i) {
    const double th = 2 * M_PI * i / 72;
    if (std::abs(std::remainder(th, 2 * M_PI)) < kPassHalfWidthRad + 0.1) continue;
    float crest = -1e9f;
    for (double r = kRimInPx * scale; r < kRimOutPx * scale; r += 0.5)
      crest = std::max(crest, h(int(std::lround(c + r * std::sin(th))), int(std::lround(c + r * std::cos(th)))));
    ++rays;
    at_sea += crest >= -1.f;
  }
  EXPECT_GE(at_sea, rays * 95 / 100) << at_sea << " of " << rays;
  // Never lowered (this model's rim lies under the reef top everywhere),
  // never lifted out of the water outside the islets.
  EXPECT_EQ(cv::countNonZero(h < before - 1e-6f), 0);
  // The lagoon's centre, the pass's throat and the open sea as the model left them.
  for (const cv::Point p : {cv::Point(N / 2, N / 2), cv::Point(int(c + (kRimInPx + 4) * scale), int(c)),
                            cv::Point(8, 8), cv::Point(N - 9, N / 2 + 40)})
    EXPECT_FLOAT_EQ(h(p), before(p)) << p;
}

// A rim the network answers with beads of land (+1 m on every other model
// cell of the ring, as the shipped model does at a painted crest) is awash
// after the finish away from the painted islets; the islets stay islets.
TEST(PaintedReef, LandBeadsOnTheCrestGoAwashAndMotuStay) {
  PaintedAtoll a = painted_atoll();
  for (int y = 0; y < kSide; ++y)
    for (int x = 0; x < kSide; ++x) {
      const double r = radius_px(x, y);
      if (a.label(y, x) == kReef && r > kRimOutPx - 3 && r < kRimOutPx - 1 && (x + y) % 4 < 2) a.model_m(y, x) = 1.f;
    }
  const int N = 4 * kSide;
  const cv::Mat1f h = finished(a, N);
  const double scale = double(N) / kSide;
  int reef_land = 0, bead_cells = 0;
  for (int y = 0; y < N; ++y)
    for (int x = 0; x < N; ++x) {
      const double mx = (x + 0.5) / scale - 0.5, my = (y + 0.5) / scale - 0.5;
      const double r = std::hypot(mx - (kSide - 1) / 2.0, my - (kSide - 1) / 2.0);
      bool by_motu = false;
      for (const cv::Point2d& m : a.motu) by_motu = by_motu || std::hypot(mx - m.x, my - m.y) < 9;
      if (r < kRimInPx + 1 || r > kRimOutPx - 1 || by_motu) continue;
      ++bead_cells;
      reef_land += h(y, x) > 0.f;
    }
  EXPECT_GT(bead_cells, 1000);
  EXPECT_EQ(reef_land, 0);
  for (const cv::Point2d& m : a.motu) {
    const cv::Point c(int((m.x + 0.5) * scale), int((m.y + 0.5) * scale));
    EXPECT_GT(h(c), 0.3f) << c;
  }
}

// Each painted islet is an islet: most of it above +0.3 m, its top 1-5 m.
TEST(PaintedReef, PaintedIsletsOnTheRingBecomeMotu) {
  const PaintedAtoll a = painted_atoll();
  const int N = 4 * kSide;
  const cv::Mat1f h = finished(a, N);
  const double scale = double(N) / kSide;
  for (const cv::Point2d& m : a.motu) {
    int cells = 0, dry = 0;
    float top = -1e9f;
    for (int y = int((m.y - 2) * scale); y <= int((m.y + 3) * scale); ++y)
      for (int x = int((m.x - 2) * scale); x <= int((m.x + 3) * scale); ++x) {
        if (std::hypot((x + 0.5) / scale - 0.5 - m.x, (y + 0.5) / scale - 0.5 - m.y) > 2) continue;
        ++cells;
        dry += h(y, x) > 0.3f;
        top = std::max(top, h(y, x));
      }
    EXPECT_GE(dry, cells / 2) << m;
    EXPECT_GT(top, 1.f) << m;
    EXPECT_LT(top, 5.f) << m;
  }
}

// A painted island is not a motu: a large island's land is the model's.
TEST(PaintedReef, LargeIslandsAndOpenSeaAreNotMotu) {
  cv::Mat1b label(kSide, kSide, uint8_t(kAbyss));
  cv::circle(label, cv::Point(64, 64), 40, cv::Scalar(kReef), -1);
  cv::circle(label, cv::Point(64, 64), 34, cv::Scalar(kIsland), -1);
  cv::circle(label, cv::Point(10, 10), 2, cv::Scalar(kBeach), -1);  // an islet in the open sea
  cv::Mat1b motu;
  const cv::Mat1f t = reef_position(label, PaintedReefParams{}, kWorldM, motu);
  EXPECT_EQ(cv::countNonZero(motu), 0);
  // t: 0 on the open sea, 1 on land, rising across the ring.
  EXPECT_EQ(t(0, 64), 0.f);
  EXPECT_EQ(t(64, 64), 1.f);
  EXPECT_LT(t(64, 64 + 39), t(64, 64 + 36));
}

TEST(PaintedReef, SameSeedSameBytesOtherSeedOtherRelief) {
  const PaintedAtoll a = painted_atoll();
  const cv::Mat1f x = finished(a, 256, 7), y = finished(a, 256, 7), z = finished(a, 256, 8);
  EXPECT_EQ(cv::norm(x, y, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(x, z, cv::NORM_INF), 0.01);
}

namespace {
int g_stops_read = 0, g_stop_at = 0;
void count_stops() {
  if (++g_stops_read == g_stop_at) throw Interrupted();
}
// Installs count_stops for a scope, and always takes it away again.
struct CountedStops {
  explicit CountedStops(int stop_at) {
    g_stops_read = 0, g_stop_at = stop_at;
    set_interrupt_hook(count_stops);
  }
  ~CountedStops() { set_interrupt_hook(nullptr); }
};
}  // namespace

// The finish runs its rows on OpenCV's threads, in bands between which a
// host's stop is read (reefgen/rows.hpp): the same bytes on 1 and 4
// threads, the stop read at least once per band of the 2048² canvas
// (with its zone fields blurred on the coarser grid, σ 8 px), and an
// Interrupted thrown there leaves the call.
TEST(PaintedReef, SameBytesWhateverTheThreadsAndAStopBetweenBands) {
  const PaintedAtoll a = painted_atoll();
  const int before = cv::getNumThreads();
  cv::setNumThreads(1);
  const cv::Mat1f one = finished(a, 2048, 7);
  cv::setNumThreads(4);
  cv::Mat1f four;
  {
    CountedStops counted(0);
    four = finished(a, 2048, 7);
    EXPECT_GE(g_stops_read, 2048 / kRowsPerBand);
  }
  cv::setNumThreads(before);
  EXPECT_EQ(cv::norm(one, four, cv::NORM_INF), 0.0);
  CountedStops stop(3);
  EXPECT_THROW(finished(a, 2048, 7), Interrupted);
  EXPECT_EQ(g_stops_read, 3);
}

// A wide motu is a low islet, not a dome: a painted islet ~470 × 210 m on a
// reef ring, which the network answered as an 8 m hill, finished and graded
// as amplify_heights does, then settled — at most the berm (2.5 m ± 20 %)
// everywhere, its inside a flat of ~2 m (real motu 1–4 m, docs/REEF.md),
// with no hollow the pit draining would breach (≤ kPitDepthM). Graded
// without settle_motu it stands as a dome over 4 m.
TEST(PaintedReef, AWideMotuIsALowIsletNotADome) {
  const PaintedReefParams p;
  cv::Mat1b label(kSide, kSide, uint8_t(kAbyss));
  cv::circle(label, {64, 64}, 52, cv::Scalar(kReef), -1);
  cv::circle(label, {64, 64}, 30, cv::Scalar(kLagoon), -1);
  const cv::Point islet(64, 23);
  cv::ellipse(label, islet, {10, 4}, 0, 0, 360, cv::Scalar(kBeach), -1);
  cv::Mat1f model_m(kSide, kSide, -60.f);
  for (int y = 0; y < kSide; ++y)
    for (int x = 0; x < kSide; ++x) {
      if (label(y, x) == kLagoon) model_m(y, x) = -25.f;
      if (label(y, x) == kReef) model_m(y, x) = -1.f;
      const double e = std::hypot((x - islet.x) / 10.0, (y - islet.y) / 4.0);
      if (e < 1.2) model_m(y, x) = float(8 * (1 - e * e / 1.44));
    }
  const int N = 4 * kSide;
  const double cell_m = kWorldM / N;
  cv::Mat1f graded;
  cv::resize(model_m, graded, cv::Size(N, N), 0, 0, cv::INTER_CUBIC);
  finish_painted_reef(graded, label, kWorldM, 5, p);
  terrain::grade_land(graded, cell_m);
  cv::Mat1f settled = graded.clone();
  settle_motu(settled, label, kWorldM, 5, p);
  cv::Mat1b inside(N, N, uint8_t(0)), middle(N, N, uint8_t(0));
  cv::ellipse(inside, islet * 4, {40, 16}, 0, 0, 360, cv::Scalar(255), -1);
  cv::ellipse(middle, islet * 4, {20, 6}, 0, 0, 360, cv::Scalar(255), -1);
  double graded_top = 0, top = 0, low = 0;
  cv::minMaxLoc(graded, nullptr, &graded_top, nullptr, nullptr, inside);
  cv::minMaxLoc(settled, &low, &top, nullptr, nullptr, inside);
  EXPECT_GT(graded_top, 4.0);
  EXPECT_LE(top, 1.2 * p.motu_height_m + 0.01);
  EXPECT_GT(top, 1.0);
  double mid_low = 0;
  cv::minMaxLoc(settled, &mid_low, nullptr, nullptr, nullptr, middle);
  EXPECT_GT(mid_low, 1.5);
  EXPECT_LT(cv::mean(settled, middle)[0], 3.0);
  // Only lowered; nothing off the islet moved.
  EXPECT_LE(cv::norm(settled, graded, cv::NORM_INF, settled > graded), 0.0);
  cv::Mat1b near;
  cv::dilate(inside, near, cv::Mat1b::ones(41, 41));
  EXPECT_EQ(cv::norm(settled, graded, cv::NORM_INF, ~near), 0.0);
  // No hollow deep enough for the pit draining to fill or breach.
  cv::Mat1f drained = settled.clone();
  EXPECT_EQ(terrain::drain_pits(drained, terrain::kPitDepthM, 5.f, cell_m), 0);
}

// No model grid in the finished top at 1:1: the zones are eased in from the
// label's cells, and bilinear weights kink at every cell edge — on the dark
// atoll's world at 4097² the reef top's curvature peaked 1.13–1.22× its
// median at the grid's phase. Measured here the same way, on the painted
// atoll finished at 8 pixels a label cell: the mean |∂²h| on the reef top
// (−2…+0.2 m) by x mod 8 (and y mod 8), peak over median, ≤ 1.1.
TEST(PaintedReef, NoModelGridInTheFinishedTop) {
  constexpr int kScale = 8;
  const PaintedAtoll a = painted_atoll();
  const cv::Mat1f h = finished(a, kScale * kSide);
  for (const bool along_x : {true, false}) {
    std::vector<double> sum(kScale, 0.0);
    std::vector<int64_t> n(kScale, 0);
    for (int y = 1; y + 1 < h.rows; ++y)
      for (int x = 1; x + 1 < h.cols; ++x) {
        if (!(h(y, x) > -2.f && h(y, x) < 0.2f)) continue;
        const float d2 = along_x ? h(y, x - 1) - 2 * h(y, x) + h(y, x + 1) : h(y - 1, x) - 2 * h(y, x) + h(y + 1, x);
        const int phase = (along_x ? x : y) % kScale;
        sum[size_t(phase)] += std::abs(d2), ++n[size_t(phase)];
      }
    std::vector<double> mean(kScale);
    for (int k = 0; k < kScale; ++k) {
      ASSERT_GT(n[size_t(k)], 1000);
      mean[size_t(k)] = sum[size_t(k)] / double(n[size_t(k)]);
    }
    std::vector<double> sorted = mean;
    std::sort(sorted.begin(), sorted.end());
    const double median = 0.5 * (sorted[kScale / 2 - 1] + sorted[kScale / 2]);
    EXPECT_LE(sorted.back() / median, 1.1) << (along_x ? "columns" : "rows");
  }
}

// No shelf seaward of the crest: a model answer that keeps a wide painted
// reef (a ring 700 m across, 30 label cells) at −5 m out to its seaward
// edge, then drops (what the network draws round a wide painted reef, seen
// from above as a ring), gets a fore reef that descends from the crest to
// the edge: going outwards along a ray it never rises by more than the top's
// relief, and a cell in from the edge it lies deeper than −8 m
// (fore_edge_m −15 at the edge itself; −5 m without it).
TEST(PaintedReef, TheForeReefDescendsFromTheCrestWithoutAShelf) {
  constexpr double kIn = 20, kOut = 50;
  cv::Mat1b label(kSide, kSide, uint8_t(kAbyss));
  cv::Mat1f model_m(kSide, kSide, -80.f);
  for (int y = 0; y < kSide; ++y)
    for (int x = 0; x < kSide; ++x) {
      const double r = radius_px(x, y);
      if (r < kIn) label(y, x) = kLagoon, model_m(y, x) = -25.f;
      else if (r < kOut) label(y, x) = kReef, model_m(y, x) = -5.f;
    }
  const int N = 4 * kSide;
  cv::Mat1f h;
  cv::resize(model_m, h, cv::Size(N, N), 0, 0, cv::INTER_NEAREST);
  finish_painted_reef(h, label, kWorldM, 1);
  const double c = (N - 1) / 2.0, scale = double(N) / kSide;
  for (int k = 0; k < 16; ++k) {
    const double th = 2 * M_PI * k / 16;
    auto at = [&](double r_label) {
      return h(int(std::lround(c + r_label * scale * std::sin(th))), int(std::lround(c + r_label * scale * std::cos(th))));
    };
    // The crest: the highest cell across the band; then outwards to the edge.
    double r_crest = kIn;
    for (double r = kIn; r < kOut; r += 0.25)
      if (at(r) > at(r_crest)) r_crest = r;
    EXPECT_GT(r_crest, kIn + 0.6 * (kOut - kIn)) << "ray " << k;
    float lowest = at(r_crest);
    for (double r = r_crest; r < kOut - 0.5; r += 0.25) {
      ASSERT_LE(at(r), lowest + 0.3f) << "ray " << k << " rises at r " << r;
      lowest = std::min(lowest, at(r));
    }
    EXPECT_LT(at(kOut - 1), -8.f) << "ray " << k;
  }
}

// The painted reef's top is the generator's (procgen CoralParams).
TEST(PaintedReef, TopIsTheGeneratorsCrestAndFlat) {
  const procgen::CoralParams coral;
  const PaintedReefParams painted;
  EXPECT_EQ(painted.crest_m, coral.crest_m);
  EXPECT_EQ(painted.flat_m, coral.flat_m);
}

// Patch reefs on a painted lagoon's floor, at four times the label's side
// (5.9 m cells): knolls rise from the floor over a share of it near the
// generator's (patch_reefs 0.3), their tops stay under water (−0.5 m at
// most), nothing outside the painted lagoon or above its floor moves, and
// the seed places them.
TEST(PaintedLagoon, PatchReefsRiseFromTheFloorAndStayUnderWater) {
  constexpr int kLabelSide = 128, kOut = 4 * kLabelSide;
  const double world_m = kCanvasWorldSizeM * kLabelSide / kModelSidePx;
  cv::Mat1b label(kLabelSide, kLabelSide, uint8_t(kAbyss));
  cv::circle(label, {64, 64}, 50, cv::Scalar(kReef), -1);
  cv::circle(label, {64, 64}, 42, cv::Scalar(kLagoon), -1);
  cv::Mat1f floor_m(kOut, kOut, -25.f);
  // A shallow shelf (−1 m) in one quarter of the lagoon: above the floor.
  floor_m(cv::Rect(kOut / 2, kOut / 2, 60, 60)).setTo(-1.f);
  cv::Mat1b lagoon_out, near_lagoon;
  cv::resize(label == kLagoon, lagoon_out, {kOut, kOut}, 0, 0, cv::INTER_NEAREST);
  // The lagoon's edge is eased over a label cell (4 px here): past it nothing moves.
  cv::dilate(lagoon_out, near_lagoon, cv::Mat1b::ones(11, 11));
  auto grown = [&](uint64_t seed) {
    cv::Mat1f h = floor_m.clone();
    grow_painted_patch_reefs(h, label, world_m, seed);
    return h;
  };
  const cv::Mat1f a = grown(3), b = grown(3), c = grown(4);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_INF), 1.0);
  int64_t lagoon = 0, knoll = 0;
  for (int y = 0; y < kOut; ++y)
    for (int x = 0; x < kOut; ++x) {
      ASSERT_GE(a(y, x), floor_m(y, x)) << "lowered at " << x << "," << y;
      if (!near_lagoon(y, x) || floor_m(y, x) > -2.f) {
        ASSERT_EQ(a(y, x), floor_m(y, x)) << "moved outside the lagoon's floor at " << x << "," << y;
        continue;
      }
      if (!lagoon_out(y, x)) continue;
      ++lagoon;
      ASSERT_LE(a(y, x), -0.5f + 1e-4f) << x << "," << y;
      if (a(y, x) > floor_m(y, x) + 1.f) ++knoll;
    }
  // The generator's rule at patch_reefs 0.3 lifts a few to ~20 % of a floor.
  const double share = double(knoll) / double(lagoon);
  EXPECT_GT(share, 0.02);
  EXPECT_LT(share, 0.35);
  // The knolls reach towards the surface: the highest top is shallower than −6 m.
  double top = -1e9;
  cv::minMaxLoc(a, nullptr, &top, nullptr, nullptr, lagoon_out & (floor_m < -2.f));
  EXPECT_GT(top, -6.0);
}
