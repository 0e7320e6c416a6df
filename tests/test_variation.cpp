// Seeds that re-roll the island (infer/variation.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/infer/variation.hpp"
#include "test_util.hpp"

using namespace reefgen;
using namespace reefgen::infer;

namespace {
constexpr int kConeSide = 128;
constexpr double kConeCellM = 23.4375;

// A cone of land 40 px in radius with its summit at (64, 64), on a sea
// floor that slopes down from the coast.
cv::Mat1f reroll_cone() {
  cv::Mat1f h(kConeSide, kConeSide);
  for (int y = 0; y < kConeSide; ++y)
    for (int x = 0; x < kConeSide; ++x) h(y, x) = float(10.0 * (40.0 - std::hypot(x - 64.0, y - 64.0)));
  return h;
}

cv::Point reroll_summit(const cv::Mat1f& h) {
  cv::Point p;
  cv::minMaxLoc(h, nullptr, nullptr, nullptr, &p);
  return p;
}
}  // namespace

TEST(Variation, KeepsTheSeaAndTheCoastAndMovesTheSummit) {
  const cv::Mat1f h = reroll_cone();
  const cv::Mat1f r = reroll_land(h, kConeCellM, 7, 1.0);
  int moved = 0;
  for (int y = 0; y < kConeSide; ++y)
    for (int x = 0; x < kConeSide; ++x) {
      if (h(y, x) <= 0) {
        ASSERT_EQ(r(y, x), h(y, x)) << "sea at " << x << "," << y;
      } else {
        ASSERT_GT(r(y, x), 0.f) << "land at " << x << "," << y;
        moved += std::abs(r(y, x) - h(y, x)) > 1.f;
      }
    }
  EXPECT_GT(moved, 1000);
  // The summit (40 px from the coast) comes from at most 0.7 · 40 = 28 px
  // away; over seeds it moves by several cells (the noise vector is small
  // for some, as a 2-D noise is near its lattice's zeros).
  std::vector<double> shifts;
  for (uint64_t seed = 1; seed <= 9; ++seed) {
    const cv::Point s = reroll_summit(reroll_land(h, kConeCellM, seed, 1.0));
    shifts.push_back(std::hypot(s.x - 64.0, s.y - 64.0));
    EXPECT_LE(shifts.back(), kRerollShiftShare * 40 + 1.5) << "seed " << seed;
  }
  std::nth_element(shifts.begin(), shifts.begin() + 4, shifts.end());
  EXPECT_GE(shifts[4], 4.0) << "median summit shift over 9 seeds";
  // The heights it takes are the cone's: the peak stays within a cell's relief.
  double hi = 0;
  cv::minMaxLoc(r, nullptr, &hi);
  EXPECT_NEAR(hi, 400.0, 10.0);
}

TEST(Variation, SameSeedSameBytesOtherSeedAnotherIsland) {
  const cv::Mat1f h = reroll_cone();
  const cv::Mat1f a = reroll_land(h, kConeCellM, 3, 1.0), b = reroll_land(h, kConeCellM, 3, 1.0);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  const cv::Mat1f c = reroll_land(h, kConeCellM, 4, 1.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_INF), 20.0);
  // Variation 0 is the answer itself; a half variation moves less than a whole one.
  EXPECT_EQ(cv::norm(reroll_land(h, kConeCellM, 3, 0.0), h, cv::NORM_INF), 0.0);
  EXPECT_LT(cv::norm(reroll_land(h, kConeCellM, 3, 0.5), h, cv::NORM_L2), cv::norm(a, h, cv::NORM_L2));
}

TEST(Variation, RefusesAVariationOutsideItsRange) {
  test::expect_error_naming([] { reroll_land(reroll_cone(), kConeCellM, 1, 1.5); }, "variation");
  test::expect_error_naming([] { reroll_land(reroll_cone(), kConeCellM, 1, std::nan("")); }, "variation");
  test::expect_error_naming([] { reroll_land(reroll_cone(), 0, 1, 1.0); }, "cell size");
}

namespace {
// A wide island of a world (~19 km across at the model's 23.4 m cells):
// a lobed outline, a paraboloid massif 430 m high, a beach ring, the sea.
cv::Mat1f reroll_wide_island() {
  constexpr int kSide = 400;
  cv::Mat1f h(kSide, kSide);
  for (int y = 0; y < kSide; ++y)
    for (int x = 0; x < kSide; ++x) {
      const double dx = x - 200.0, dy = y - 200.0, th = std::atan2(dy, dx);
      const double r = std::hypot(dx, dy) / (1 + 0.08 * std::sin(3 * th + 0.5) + 0.05 * std::sin(5 * th + 1.3));
      h(y, x) = r < 140 ? float(430 * (1 - (r / 140) * (r / 140))) : r < 155 ? 2.f : -20.f;
    }
  return h;
}

// The largest second difference (along x, y and the diagonals, per px of
// step) over the cells whose 3×3 neighbourhood is all above 60 m: on the
// massif, away from where it meets the beach.
double worst_kink(const cv::Mat1f& h) {
  double w = 0;
  for (int y = 1; y < h.rows - 1; ++y)
    for (int x = 1; x < h.cols - 1; ++x) {
      bool high = true;
      for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i) high &= h(y + j, x + i) > 60.f;
      if (!high) continue;
      const float c2 = 2 * h(y, x);
      w = std::max({w, double(std::abs(h(y, x + 1) - c2 + h(y, x - 1))), double(std::abs(h(y + 1, x) - c2 + h(y - 1, x))),
                    0.5 * std::abs(h(y + 1, x + 1) - c2 + h(y - 1, x - 1)),
                    0.5 * std::abs(h(y + 1, x - 1) - c2 + h(y - 1, x + 1))});
    }
  return w;
}
}  // namespace

// The distance to the coast creases along the island's medial axis; a warp
// ∝ it folded the massif into Vs there (second differences of 2.2–4.4 m
// on this island, seeds 0–3) and, where they met on a world's island,
// into closed basins that the erosion deepened and the pit draining cut
// straight gorges out of. The warp's own bend leaves ~1.4 m.
TEST(Variation, ARerolledMassifIsNotFoldedAlongItsMedialAxis) {
  const cv::Mat1f h = reroll_wide_island();
  ASSERT_LT(worst_kink(h), 0.2);
  for (uint64_t seed = 0; seed < 4; ++seed)
    EXPECT_LT(worst_kink(reroll_land(h, kConeCellM, seed, 1.0)), 1.8) << "seed " << seed;
}

TEST(Variation, TheCreaselessDistanceIsBelowTheDistanceAndSmoothAcrossItsCreases) {
  // A square island: the distance creases along both diagonals.
  cv::Mat1b land(81, 81, uchar(0));
  land(cv::Rect(10, 10, 61, 61)) = 255;
  cv::Mat1f d;
  cv::distanceTransform(land, d, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  const cv::Mat1f s = creaseless_distance(d);
  double worst_curl_d = 0, worst_curl_s = 0;
  for (int y = 1; y < 80; ++y)
    for (int x = 1; x < 80; ++x) {
      ASSERT_LE(s(y, x), d(y, x) + 1e-5f) << x << "," << y;
      if (!land(y, x)) {
        ASSERT_EQ(s(y, x), 0.f);
      }
      // 1-Lipschitz: the warp cannot fold.
      ASSERT_LE(std::abs(s(y, x + 1) - s(y, x)), 1.f + 1e-4f);
      ASSERT_LE(std::abs(s(y + 1, x) - s(y, x)), 1.f + 1e-4f);
      // Second differences along x inside the island: the crease's kink.
      if (x > 12 && x < 68 && y > 12 && y < 68) {
        worst_curl_d = std::max(worst_curl_d, double(std::abs(d(y, x + 1) - 2 * d(y, x) + d(y, x - 1))));
        worst_curl_s = std::max(worst_curl_s, double(std::abs(s(y, x + 1) - 2 * s(y, x) + s(y, x - 1))));
      }
    }
  EXPECT_GT(worst_curl_d, 0.9);  // the crease: the slope turns from +1 to −1 across a cell or two
  EXPECT_LT(worst_curl_s, 0.3);
  // Near the coast it is the distance itself (within 2 %).
  EXPECT_NEAR(s(40, 12), d(40, 12), 0.02 * d(40, 12));
}

// No sea on the canvas: the distance to it reads unbounded (~3·10⁷ px), and
// a blur that wide once took all the memory there was.
TEST(Variation, ACanvasWithoutSeaIsReRolledAsLandAndFinite) {
  cv::Mat1f h(64, 64);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) h(y, x) = float(5 + 100 * std::exp(-((x - 32.0) * (x - 32.0) + (y - 32.0) * (y - 32.0)) / 400));
  const cv::Mat1f r = reroll_land(h, kConeCellM, 2, 1.0);
  ASSERT_EQ(r.size(), h.size());
  EXPECT_TRUE(cv::checkRange(r));
  double lo = 0, hi = 0;
  cv::minMaxLoc(r, &lo, &hi);
  EXPECT_GT(lo, 0.0);
  EXPECT_LE(hi, 105.5);
}
