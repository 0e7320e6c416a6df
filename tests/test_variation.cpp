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
