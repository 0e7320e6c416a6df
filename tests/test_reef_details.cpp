// Seeded passes and motu on a painted reef ring (infer/reef_details.hpp): a
// closed painted atoll rim gets passes on one side and motu on its flat, each
// seed its own; what the painting shows (a gap, islets) is left as painted;
// the passes cut the finished crest and the motu come up as islets.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/infer/reef_details.hpp"
#include "reefgen/infer/reef_finish.hpp"
#include "reefgen/labels.hpp"

namespace {

constexpr int kRingSide = 256;
constexpr double kRingCellM = reefgen::kCanvasWorldSizeM / reefgen::kModelSidePx;
constexpr double kRingOutPx = 100, kRingInPx = 90;

// A closed atoll rim (reef), lagoon inside, abyss outside; and what a
// blurring model answers for it (rim −6 m, lagoon −25 m, sea −80 m).
cv::Mat1b ring_label() {
  cv::Mat1b label(kRingSide, kRingSide, uint8_t(reefgen::kAbyss));
  cv::circle(label, cv::Point(kRingSide / 2, kRingSide / 2), int(kRingOutPx), cv::Scalar(reefgen::kReef), -1);
  cv::circle(label, cv::Point(kRingSide / 2, kRingSide / 2), int(kRingInPx), cv::Scalar(reefgen::kLagoon), -1);
  return label;
}

cv::Mat1f ring_answer(const cv::Mat1b& label) {
  cv::Mat1f h(label.size(), -80.f);
  h.setTo(-6.f, label == reefgen::kReef);
  h.setTo(-25.f, label == reefgen::kLagoon);
  cv::GaussianBlur(h, h, cv::Size(0, 0), 1.5);
  return h;
}

cv::Point2d middle(const reefgen::infer::SeededReefDetails::Pass& p) { return p.middle_m(); }

double angle_of(const cv::Point2d& m) {
  const double c = 0.5 * kRingSide * kRingCellM;
  return std::atan2(m.y - c, m.x - c);
}

}  // namespace

TEST(SeededReefDetails, AClosedRingGetsPassesAndMotuEachSeedItsOwn) {
  using namespace reefgen::infer;
  const cv::Mat1b label = ring_label();
  const SeededReefDetails a = plan_reef_details(label, {}, kRingCellM, 1, 1.0);
  const SeededReefDetails b = plan_reef_details(label, {}, kRingCellM, 2, 1.0);
  // The rim is ~14 km long: two passes, and motu as the generator's atoll has (6; one may find no room).
  ASSERT_EQ(a.passes.size(), 2u);
  ASSERT_EQ(b.passes.size(), 2u);
  EXPECT_GE(a.motu.size(), 5u);
  EXPECT_LE(a.motu.size(), 6u);
  EXPECT_GE(b.motu.size(), 5u);
  // Both passes on one (leeward) side: within 120° of each other.
  EXPECT_LE(std::fabs(std::remainder(angle_of(middle(a.passes[0])) - angle_of(middle(a.passes[1])), 2 * M_PI)),
            2 * M_PI / 3 + 1e-9);
  // Each pass crosses the rim: its ends inside the lagoon and out at sea.
  for (const auto& p : a.passes) {
    const double c = 0.5 * kRingSide * kRingCellM;
    EXPECT_LT(std::hypot(p.path_m.front().x - c, p.path_m.front().y - c) / kRingCellM, kRingInPx);
    EXPECT_GT(std::hypot(p.path_m.back().x - c, p.path_m.back().y - c) / kRingCellM, kRingOutPx);
    EXPECT_GE(p.width_m, 100.0);
    EXPECT_LE(p.width_m, 260.0);
  }
  // Another seed, other places.
  EXPECT_GT(cv::norm(middle(a.passes[0]) - middle(b.passes[0])), 200.0);
  // Same seed, same plan; variation 0 (the network's own island), none.
  const SeededReefDetails again = plan_reef_details(label, {}, kRingCellM, 1, 1.0);
  ASSERT_EQ(again.motu.size(), a.motu.size());
  for (size_t i = 0; i < a.motu.size(); ++i) EXPECT_EQ(again.motu[i].centre_m, a.motu[i].centre_m);
  EXPECT_TRUE(plan_reef_details(label, {}, kRingCellM, 1, 0.0).empty());
  // A young fringing reef's ring (subsidence 0) gets passes but no motu.
  const SeededReefDetails young = plan_reef_details(label, cv::Mat1f(label.size(), 0.f), kRingCellM, 1, 1.0);
  EXPECT_EQ(young.passes.size(), 2u);
  EXPECT_TRUE(young.motu.empty());
}

TEST(SeededReefDetails, WhatThePaintingShowsIsLeftAsPainted) {
  using namespace reefgen::infer;
  // A painted pass (lagoon through the rim to the sea, due east): no seeded pass.
  cv::Mat1b gap = ring_label();
  cv::rectangle(gap, cv::Rect(kRingSide / 2 + 80, kRingSide / 2 - 4, 40, 8), cv::Scalar(reefgen::kLagoon), -1);
  const SeededReefDetails g = plan_reef_details(gap, {}, kRingCellM, 1, 1.0);
  EXPECT_TRUE(g.passes.empty());
  EXPECT_FALSE(g.motu.empty());
  // Painted islets on the rim: no seeded motu.
  cv::Mat1b islets = ring_label();
  cv::circle(islets, cv::Point(kRingSide / 2, kRingSide / 2 - 95), 3, cv::Scalar(reefgen::kBeach), -1);
  const SeededReefDetails i = plan_reef_details(islets, {}, kRingCellM, 1, 1.0);
  EXPECT_TRUE(i.motu.empty());
  EXPECT_EQ(i.passes.size(), 2u);
  // Two painted islets across the whole band cut the reef in two arcs: both
  // are still the ring with painted islets.
  cv::Mat1b across = ring_label();
  cv::rectangle(across, cv::Rect(kRingSide / 2 - 3, kRingSide / 2 - 103, 6, 16), cv::Scalar(reefgen::kBeach), -1);
  cv::rectangle(across, cv::Rect(kRingSide / 2 - 3, kRingSide / 2 + 87, 6, 16), cv::Scalar(reefgen::kBeach), -1);
  EXPECT_TRUE(plan_reef_details(across, {}, kRingCellM, 1, 1.0).motu.empty());
  // A reef with no lagoon behind it (a fringing reef on a coast): nothing.
  cv::Mat1b fringing = ring_label();
  fringing.setTo(reefgen::kIsland, fringing == reefgen::kLagoon);
  EXPECT_TRUE(plan_reef_details(fringing, {}, kRingCellM, 1, 1.0).empty());
}

TEST(SeededReefDetails, PassesCutTheFinishedCrestAndMotuAreIslets) {
  using namespace reefgen::infer;
  cv::Mat1b label = ring_label();
  const SeededReefDetails d = plan_reef_details(label, {}, kRingCellM, 3, 1.0);
  ASSERT_FALSE(d.passes.empty());
  ASSERT_FALSE(d.motu.empty());
  const cv::Mat1f answer = ring_answer(label);
  paint_seeded_motu(label, d, kRingCellM);
  const int N = 2 * kRingSide;
  const double out_m = kRingCellM / 2;
  cv::Mat1f h;
  cv::resize(answer, h, cv::Size(N, N), 0, 0, cv::INTER_CUBIC);
  finish_painted_reef(h, label, kRingSide * kRingCellM, 3);
  const cv::Mat1f before = h.clone();
  cut_seeded_passes(h, label, d, out_m, 3);
  // Only lowered.
  cv::Mat1f rise = h - before;
  double most = 0;
  cv::minMaxLoc(rise, nullptr, &most);
  EXPECT_LE(most, 0.0);
  // The crest is awash before the cut and the pass's floor after it, at least 8 m × 0.85 down.
  for (const auto& p : d.passes) {
    const cv::Point2d m = middle(p) / out_m;
    const cv::Point c(int(m.x), int(m.y));
    EXPECT_LT(h(c), -6.5f) << c;
  }
  // Each seeded motu is an islet: most of its middle third above +0.3 m.
  for (const auto& m : d.motu) {
    int cells = 0, dry = 0;
    const cv::Point2d c = m.centre_m / out_m;
    const double r = std::max(1.0, m.half_wid_m / out_m / 3);
    for (int y = int(c.y - r); y <= int(c.y + r); ++y)
      for (int x = int(c.x - r); x <= int(c.x + r); ++x) {
        if (std::hypot(x + 0.5 - c.x, y + 0.5 - c.y) > r) continue;
        ++cells;
        dry += h(y, x) > 0.3f;
      }
    EXPECT_GE(2 * dry, cells) << c;
  }
  // Land is never cut: a pass across painted land leaves it.
  cv::Mat1f land(N, N, 5.f);
  cut_seeded_passes(land, cv::Mat1b(kRingSide, kRingSide, uint8_t(reefgen::kIsland)), d, out_m, 3);
  EXPECT_EQ(cv::countNonZero(land != 5.f), 0);
}

// Across a wide ring (~940 m) a pass winds, as real passes do across a reef
// flat: a straight cut that long reads as a canal at 1:1.
TEST(SeededReefDetails, APassAcrossAWideRingWinds) {
  using namespace reefgen::infer;
  cv::Mat1b label(kRingSide, kRingSide, uint8_t(reefgen::kAbyss));
  cv::circle(label, cv::Point(kRingSide / 2, kRingSide / 2), 110, cv::Scalar(reefgen::kReef), -1);
  cv::circle(label, cv::Point(kRingSide / 2, kRingSide / 2), 70, cv::Scalar(reefgen::kLagoon), -1);
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    const SeededReefDetails d = plan_reef_details(label, {}, kRingCellM, seed, 1.0);
    ASSERT_FALSE(d.passes.empty());
    for (const auto& p : d.passes) {
      // Its centre line strays from the straight line between its ends by half its width or more.
      const cv::Point2d ab = p.path_m.back() - p.path_m.front();
      double stray = 0;
      for (const auto& q : p.path_m) stray = std::max(stray, std::fabs(ab.cross(q - p.path_m.front())) / std::hypot(ab.x, ab.y));
      EXPECT_GE(stray, 0.5 * p.width_m) << "seed " << seed;
      EXPECT_GT(std::hypot(ab.x, ab.y), 900.0);
    }
  }
}
