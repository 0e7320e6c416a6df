// Augmentation: alignment of label and height, exactness of the simple
// cases, wrap continuity, the IoU bound of copy-paste.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/augment/augment.hpp"
#include "reefgen/augment/build.hpp"
#include "reefgen/augment/dataset.hpp"
#include "reefgen/augment/formats.hpp"
#include "reefgen/augment/manifest.hpp"
#include "reefgen/age.hpp"
#include "reefgen/files.hpp"
#include "test_util.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/random_spec.hpp"
#include <algorithm>
#include <fstream>
#include <cstring>
#include <map>
#include <set>
#include <sstream>
#include <opencv2/imgcodecs.hpp>

using namespace reefgen;
using namespace reefgen::augment;

namespace {

Pair island_pair(uint64_t index, int W, double scale = 1.0) {
  auto spec = procgen::random_spec(77, index);
  spec.subsidence = 0.1 * index;
  procgen::RenderOptions o;
  o.size_px = W;
  const auto f = procgen::generate(spec, o);
  Pair p{f.height_m, f.label, cv::Mat1f(W, W, float(spec.subsidence))};
  return scale == 1.0 ? p : affine(p, 0, scale, false);
}

// Height = 10 m × label id: lets a test see whether label and height moved together.
Pair stepped(int W) {
  Pair p{cv::Mat1f(W, W), cv::Mat1b(W, W), cv::Mat1f(W, W, 0.f)};
  for (int y = 0; y < W; ++y)
    for (int x = 0; x < W; ++x) {
      const double r = std::hypot(x - 20.0, y - 27.0) / W;
      p.label(y, x) = static_cast<uint8_t>(std::min(4, static_cast<int>(r / 0.1)));
      p.height_m(y, x) = 10.f * p.label(y, x);
      p.subsidence(y, x) = x / float(W);
    }
  return p;
}

bool equal(const cv::Mat& a, const cv::Mat& b) { return cv::norm(a, b, cv::NORM_INF) == 0; }

}  // namespace

TEST(Affine, IdentityIsExact) {
  const Pair p = island_pair(1, 48);
  const Pair q = affine(p, 0, 1, false);
  EXPECT_TRUE(equal(p.height_m, q.height_m));
  EXPECT_TRUE(equal(p.label, q.label));
}

TEST(Affine, QuarterTurnAndFlipMatchExactPermutations) {
  const Pair p = stepped(40);
  const Pair r = affine(p, 90, 1, false);
  cv::Mat expected;
  cv::rotate(p.label, expected, cv::ROTATE_90_COUNTERCLOCKWISE);
  EXPECT_TRUE(equal(r.label, expected));
  cv::rotate(p.height_m, expected, cv::ROTATE_90_COUNTERCLOCKWISE);
  EXPECT_LT(cv::norm(r.height_m, expected, cv::NORM_INF), 1e-3);
  const Pair f = affine(p, 0, 1, true);
  cv::flip(p.label, expected, 1);
  EXPECT_TRUE(equal(f.label, expected));
  cv::flip(p.subsidence, expected, 1);
  EXPECT_TRUE(equal(f.subsidence, expected));
}

TEST(Affine, LabelsNeverBlendedAndStayAlignedWithHeights) {
  const Pair p = stepped(64);
  const Pair q = affine(p, 37, 0.8, true, /*ocean_m=*/40.0);  // this pair's abyss is 10 m × 4
  int exact = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      ASSERT_LE(q.label(y, x), 4);
      // Bilinear heights lie within one step of the nearest label's height.
      ASSERT_LE(std::fabs(q.height_m(y, x) - 10.f * q.label(y, x)), 10.f + 1e-3f);
      exact += std::fabs(q.height_m(y, x) - 10.f * q.label(y, x)) < 1e-3f;
    }
  EXPECT_GT(exact, 64 * 64 * 8 / 10);
}

TEST(TranslateWrap, ContinuityAndComposition) {
  const Pair p = stepped(32);
  const Pair a = translate_wrap(p, 5, -3);
  EXPECT_EQ(a.label(0, 4), p.label(3, 31));  // column 31 wrapped to column 4, row 3 to row 0
  EXPECT_EQ(a.height_m(10, 5), p.height_m(13, 0));
  EXPECT_TRUE(equal(translate_wrap(p, 32, -64).label, p.label));
  const Pair b = translate_wrap(translate_wrap(p, 7, 2), 30, 31);
  const Pair c = translate_wrap(p, 37, 33);
  EXPECT_TRUE(equal(b.label, c.label));
  EXPECT_TRUE(equal(b.height_m, c.height_m));
  EXPECT_TRUE(equal(b.subsidence, c.subsidence));
}

TEST(CopyPaste, IoUBoundMergeRulesAndAbyssElsewhere) {
  std::vector<Pair> isl;
  for (int i = 0; i < 3; ++i) isl.push_back(island_pair(i, 64, 0.45));
  const auto r = copy_paste(isl, 5, 0.10);
  ASSERT_GE(r.placed, 2);
  std::vector<Pair> moved;
  for (int i = 0; i < r.placed; ++i) moved.push_back(translate_wrap(isl[i], r.offsets[i].x, r.offsets[i].y));
  for (int i = 0; i < r.placed; ++i)
    for (int j = i + 1; j < r.placed; ++j) EXPECT_LE(iou(footprint(moved[i]), footprint(moved[j])), 0.10);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      ASSERT_LE(r.pair.label(y, x), 4);
      float top = -1e9f;
      int owner = -1;
      bool covered = false;
      for (int i = 0; i < r.placed; ++i) {
        if (moved[i].height_m(y, x) > top) top = moved[i].height_m(y, x), owner = i;
        covered = covered || moved[i].label(y, x) != kAbyss;
      }
      ASSERT_GE(r.pair.height_m(y, x), top - 1e-4f);  // smooth max ≥ max
      // Overshoot ≤ 1/(2k) = 1 m per merge: the abyss floor rises by up to (n − 1) m.
      ASSERT_LE(r.pair.height_m(y, x), top + 1.0f * (r.placed - 1) + 1e-4f);
      if (!covered) {
        ASSERT_EQ(r.pair.label(y, x), kAbyss);
      } else if (owner >= 0 && r.pair.label(y, x) != kAbyss) {
        ASSERT_EQ(r.pair.label(y, x), moved[owner].label(y, x));
      }
    }
  // Deterministic in the seed.
  EXPECT_TRUE(equal(copy_paste(isl, 5, 0.10).pair.height_m, r.pair.height_m));
}

TEST(CopyPaste, Errors) {
  EXPECT_THROW(copy_paste({}, 1), Error);
  std::vector<Pair> mixed = {island_pair(0, 32), island_pair(1, 48)};
  EXPECT_THROW(copy_paste(mixed, 1), Error);
}

TEST(Affine, OutsideTheCanvasIsOpenOcean) {
  // An island cut by the canvas edge: shrinking it must not smear the edge.
  Pair p{cv::Mat1f(32, 32, -100.f), cv::Mat1b(32, 32, uint8_t(kAbyss)), cv::Mat1f(32, 32, 0.f)};
  p.label.col(31).setTo(kIsland);
  p.height_m.col(31).setTo(50.f);
  const Pair q = affine(p, 0, 0.5, false);
  EXPECT_EQ(q.label(0, 0), kAbyss);
  EXPECT_EQ(q.label(16, 31), kAbyss);  // was replicated land before
  EXPECT_FLOAT_EQ(q.height_m(16, 31), -100.f);
  EXPECT_EQ(cv::countNonZero(q.label == kIsland), 16);  // the edge column, shrunk to half, inside
}

// A sea floor with relief is continued past the canvas edge, not cut to a
// constant: no step along the rotated canvas.
TEST(Affine, OutsideContinuesTheSeaFloorWithoutAStep) {
  Pair p{cv::Mat1f(64, 64), cv::Mat1b(64, 64, uint8_t(kAbyss)), cv::Mat1f(64, 64, 0.f)};
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) p.height_m(y, x) = -97.f + 0.02f * float(x);  // a gentle slope, −97…−95.7 m
  const Pair q = affine(p, 30, 0.8, false);
  float step = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x + 1 < 64; ++x) step = std::max(step, std::fabs(q.height_m(y, x + 1) - q.height_m(y, x)));
  EXPECT_LT(step, 0.2f);  // a constant −100 m fill stepped ≥ 2 m
  double lo, hi;
  cv::minMaxLoc(q.height_m, &lo, &hi);
  EXPECT_GE(lo, -97.01);
}

// Median height of the abyss cells whose distance from the nearest other
// cell is in [d, d + 1) px.
double abyss_median_at(const Pair& p, double d) {
  cv::Mat1f dist;
  cv::distanceTransform(p.label == kAbyss, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  std::vector<float> v;
  for (int y = 0; y < dist.rows; ++y)
    for (int x = 0; x < dist.cols; ++x)
      if (p.label(y, x) == kAbyss && dist(y, x) >= d && dist(y, x) < d + 1) v.push_back(p.height_m(y, x));
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// The redrawn sea floor follows the canvas the pair ends up in: one island
// shrunk to 0.6 or left at 1 has, at the same distance in pixels from its
// reef, the same sea floor (it differed by metres before the redraw: the
// descent had been drawn at the generator's scale), the foot at the reef and
// the floor approached as the flank says; other cells are untouched.
TEST(RedrawFlank, FollowsTheCanvasNotTheAugmentationScale) {
  const int W = 128;
  const Pair big = island_pair(2, W), small = island_pair(2, W, 0.6);
  const FlankShape f{6000.0 / W, -100, -80, 900, 4};
  const Pair big_r = redraw_flank(big, f, 5), small_r = redraw_flank(small, f, 5);
  for (double d : {6.0, 12.0, 20.0}) {
    EXPECT_NEAR(abyss_median_at(big_r, d), abyss_median_at(small_r, d), 0.6) << d;
    // flank_height_m's fall from −80 m to a −100 m floor, 19 m: a quarter
    // e-folding over 900 m, the rest as 1 − tanh(d / decay).
    const double x_m = d * f.metres_per_px;
    const double flank = -99 + 0.25 * 19 * std::exp(-x_m / 900) + 0.75 * 19 * (1 - std::tanh(x_m / 900));
    EXPECT_NEAR(abyss_median_at(big_r, d), flank + 2, 1.5) << d;  // + the relief's mean, 2 m far out
  }
  EXPECT_GT(std::fabs(abyss_median_at(big, 12) - abyss_median_at(small, 12)), 1.0);  // what the redraw removes
  EXPECT_NEAR(abyss_median_at(big_r, 1), -80, 1.0);
  const cv::Mat1b other = big.label != kAbyss;
  EXPECT_EQ(cv::norm(big.height_m, big_r.height_m, cv::NORM_INF, other), 0.0);
  EXPECT_EQ(cv::norm(big.label, big_r.label, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(redraw_flank(big, f, 5).height_m, big_r.height_m, cv::NORM_INF), 0.0);  // deterministic
  EXPECT_GT(cv::norm(redraw_flank(big, f, 6).height_m, big_r.height_m, cv::NORM_INF), 0.0);  // the seed is the relief's
  // No abyss at all: unchanged.
  Pair land{cv::Mat1f(16, 16, 5.f), cv::Mat1b(16, 16, uint8_t(kIsland)), cv::Mat1f(16, 16, 0.f)};
  EXPECT_EQ(cv::norm(redraw_flank(land, f, 1).height_m, land.height_m, cv::NORM_INF), 0.0);
}

// A rotated, shrunk and wrapped pair: the canvas edges moved inwards drew
// straight creases on the sea floor; redrawn, the floor has none (the
// largest curvature far from the reef stays that of the relief).
TEST(RedrawFlank, LeavesNoSeamsOfTheMovedCanvas) {
  const int W = 128;
  const Pair moved = translate_wrap(affine(island_pair(3, W), 30, 0.7, false), 37, 11);
  const Pair redrawn = redraw_flank(moved, FlankShape{6000.0 / W, -100, -80, 900, 4}, 2);
  cv::Mat1f dist;
  cv::distanceTransform(moved.label == kAbyss, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  auto max_curvature = [&](const cv::Mat1f& h) {
    float c = 0;
    for (int y = 1; y + 1 < W; ++y)
      for (int x = 1; x + 1 < W; ++x)
        if (dist(y, x) > 6)
          c = std::max({c, std::fabs(h(y, x - 1) - 2 * h(y, x) + h(y, x + 1)),
                        std::fabs(h(y - 1, x) - 2 * h(y, x) + h(y + 1, x))});
    return c;
  };
  EXPECT_GT(max_curvature(moved.height_m), 0.5f);  // the seams
  EXPECT_LT(max_curvature(redrawn.height_m), 0.25f);
}

// The dataset key: off by default (earlier datasets byte for byte), on it
// redraws curve pairs and says so in the pair's record.
TEST(Dataset, RedrawFlankIsAKeyAndRecorded) {
  DatasetParams p;
  p.size_px = 64;
  p.p_affine = 1;
  PairInfo off_info, on_info;
  const Pair off = make_pair(3, 4, p, &off_info);
  p.redraw_flank = true;
  const Pair on = make_pair(3, 4, p, &on_info);
  EXPECT_FALSE(off_info.augmentation.contains("flank_redrawn"));
  EXPECT_TRUE(on_info.augmentation.value("flank_redrawn", false));
  EXPECT_EQ(cv::norm(off.label, on.label, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(off.height_m, on.height_m, cv::NORM_INF, on.label == kAbyss), 0.0);
  EXPECT_EQ(cv::norm(off.height_m, on.height_m, cv::NORM_INF, on.label != kAbyss), 0.0);
}

TEST(Dataset, OtherIslandSystemsAsPairs) {
  DatasetParams p;
  p.size_px = 48;
  p.p_paste = 0;
  const Pair curves = augment::make_pair(5, 3, p);
  // The options draw from their own RNG stream: probabilities too small to
  // fire leave the curve pair byte-identical (a draw from the pair's own
  // stream would shift every later choice and change it).
  p.p_wilbur = 1e-12;
  p.p_mapgen4 = 1e-12;
  EXPECT_EQ(cv::norm(augment::make_pair(5, 3, p).height_m, curves.height_m, cv::NORM_INF), 0.0);
  p.p_wilbur = 0;
  p.p_mapgen4 = 1;
  PairInfo info;
  const Pair m4 = augment::make_pair(5, 3, p, &info);
  EXPECT_EQ(info.augmentation.at("source"), "mapgen4");
  EXPECT_EQ(info.subsidence, 0.0);
  EXPECT_EQ(cv::norm(m4.height_m, augment::make_pair(5, 3, p).height_m, cv::NORM_INF), 0.0);  // deterministic
  // Labels follow the height bands: land is mountain or beach, deep water abyss
  // (before any affine move; check with augmentation off).
  p.p_affine = 0;
  p.p_translate = 0;
  const Pair plain = augment::make_pair(5, 3, p);
  for (int r = 0; r < 48; ++r)
    for (int c = 0; c < 48; ++c) {
      const bool land = plain.label(r, c) == kIsland || plain.label(r, c) == kBeach;
      EXPECT_EQ(land, plain.height_m(r, c) >= 0) << r << "," << c;
    }
  p.p_mapgen4 = 0.6;
  p.p_wilbur = 0.6;
  EXPECT_THROW(dataset_params_from_json(nlohmann::json(p), "cfg"), Error);
}

// No pair may show an island cut by a straight line inside the
// canvas. A wrap translation is the only way such a line appears, so undo it
// and check that the canvas it moved had an all-abyss border ring. Also: the
// rule must have had work to do (translations happened and some were refused).
TEST(Dataset, WholeIslandsBeforeEveryWrapTranslation) {
  DatasetParams p = dataset_params_from_json(read_json(std::string(REEFGEN_SOURCE_DIR) + "/configs/dataset/shipped.json"), "shipped.json");
  p.size_px = 64;  // same recipe, tiny canvas: 500+ pairs in a second or two
  p.p_translate = 0.6;
  p.p_erosion = 0;  // heights do not matter here
  int translated = 0, skipped = 0, pasted = 0;
  for (int64_t i = 0; i < 520; ++i) {
    PairInfo info;
    const Pair pair = make_pair(3, i, p, &info);
    if (info.augmentation.contains("paste")) ++pasted;
    if (info.augmentation.contains("translate_skipped")) ++skipped;
    if (!info.augmentation.contains("translate")) continue;
    ++translated;
    const int dx = info.augmentation["translate"][0], dy = info.augmentation["translate"][1];
    const Pair before = translate_wrap(pair, -dx, -dy);
    ASSERT_TRUE(border_is_abyss(before.label, p.border_px)) << "pair " << i << " was translated with land on the border";
    // Heights on that ring are open ocean too (no seam in the height field).
    for (int x = 0; x < 64; ++x) {
      ASSERT_LT(before.height_m(0, x), -60.f) << "pair " << i;
      ASSERT_LT(before.height_m(x, 0), -60.f) << "pair " << i;
    }
  }
  EXPECT_GT(translated, 150);
  EXPECT_GT(skipped, 5);  // islands do touch the border (scale > 1, wind): the rule was exercised
  EXPECT_GT(pasted, 50);
}

TEST(Dataset, BorderIsAbyss) {
  cv::Mat1b l(16, 16, uint8_t(kAbyss));
  EXPECT_TRUE(border_is_abyss(l, 2));
  l(1, 8) = 0;  // inside the 2-px ring
  EXPECT_FALSE(border_is_abyss(l, 2));
  EXPECT_TRUE(border_is_abyss(l, 1));
}

TEST(Dataset, ContinuousSubsidenceCoversTheRange) {
  DatasetParams p;
  p.size_px = 32;
  p.continuous_subsidence = true;
  p.levels = 3;
  std::vector<double> lams;
  for (int64_t i = 0; i < 300; ++i) lams.push_back(pair_info(9, i, p).subsidence);
  std::sort(lams.begin(), lams.end());
  lams.erase(std::unique(lams.begin(), lams.end()), lams.end());
  EXPECT_EQ(lams.size(), 300u);  // every pair its own value, not 3 levels
  EXPECT_LT(lams.front(), 0.02);
  EXPECT_GT(lams.back(), 0.98);
  // The ladder configs are unchanged: 4 levels, exactly the paper's values.
  DatasetParams ladder = dataset_params_from_json(read_json(std::string(REEFGEN_SOURCE_DIR) + "/configs/dataset/paper.json"), "paper.json");
  EXPECT_FALSE(ladder.continuous_subsidence);
  EXPECT_DOUBLE_EQ(pair_info(9, 5, ladder).subsidence, 1.0 / 3.0);
}

// Ages for conditioning: each pair draws an age in the range (log-uniform),
// which sets its subsidence and maturity; the pair is the generator's island
// of that maturity; without ages nothing changes (maturity 1, no age).
TEST(Dataset, AgesAreDrawnRecordedAndApplied) {
  DatasetParams p;
  p.size_px = 32;
  p.p_erosion = 1;
  p.p_affine = p.p_translate = p.p_paste = 0;
  const PairInfo plain = pair_info(9, 3, p);
  EXPECT_EQ(plain.age_myr, -1.0);
  EXPECT_EQ(plain.maturity, 1.0);
  EXPECT_EQ(plain.ruggedness, 1.0);
  EXPECT_EQ(plain.seed, procgen::random_spec(9, uint64_t(plain.configuration)).noise.seed);
  DatasetParams aged = p;
  aged.age_min_myr = 0.1, aged.age_max_myr = 8;
  std::vector<double> ages;
  for (int64_t i = 0; i < 200; ++i) {
    const PairInfo a = pair_info(9, i, aged);
    ASSERT_GE(a.age_myr, 0.1);
    ASSERT_LE(a.age_myr, 8.0);
    EXPECT_DOUBLE_EQ(a.subsidence, subsidence_of_age(a.age_myr));
    EXPECT_DOUBLE_EQ(a.maturity, maturity_of_age(a.age_myr));
    ages.push_back(a.age_myr);
  }
  // Log-uniform: about half the draws below the geometric mean (0.89 My).
  const auto below = std::count_if(ages.begin(), ages.end(), [](double t) { return t < std::sqrt(0.1 * 8); });
  EXPECT_NEAR(double(below) / 200, 0.5, 0.1);
  // The pair is the island of its maturity: differs from the unaged one.
  PairInfo got;
  const Pair a = make_pair(9, 3, aged, &got);
  EXPECT_EQ(got.age_myr, pair_info(9, 3, aged).age_myr);
  EXPECT_GT(cv::norm(a.height_m, make_pair(9, 3, p).height_m, cv::NORM_INF), 0.5);
  // The manifest records each pair's seed, age, maturity, style and subsidence.
  const fs::path d = test::temp_dir("ages");
  aged.count = 3;
  BuildOptions o;
  o.seed = 9;
  o.quiet = true;
  o.out = d;
  build_dataset(aged, o);
  std::ifstream manifest(d / "manifest.jsonl");
  std::string line;
  int rows = 0;
  while (std::getline(manifest, line)) {
    const nlohmann::json rec = nlohmann::json::parse(line);
    const PairInfo want = pair_info(9, rec["index"].get<int64_t>(), aged);
    EXPECT_EQ(rec["age_myr"].get<double>(), want.age_myr);
    EXPECT_EQ(rec["seed"].get<uint64_t>(), want.seed);
    EXPECT_EQ(rec["maturity"].get<double>(), want.maturity);
    EXPECT_EQ(rec["subsidence"].get<double>(), want.subsidence);
    EXPECT_EQ(rec["ruggedness"].get<double>(), 1.0);
    ++rows;
  }
  EXPECT_EQ(rows, 3);
  fs::remove_all(d);
  DatasetParams bad = p;
  bad.age_min_myr = 5, bad.age_max_myr = 1;
  EXPECT_THROW(dataset_params_from_json(params_json(bad), "d.json"), Error);
}

TEST(Dataset, ConfigErrorsNameTheKey) {
  auto err = [](const char* text) {
    try {
      dataset_params_from_json(nlohmann::json::parse(text), "x.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(err(R"({"continuous_subsidence": 1})").find("x.json: continuous_subsidence = 1 must be true or false"), std::string::npos);
  EXPECT_NE(err(R"({"border_px": 2.5})").find("border_px"), std::string::npos);
  EXPECT_NE(err(R"({"subsidence_min": 0.5, "subsidence_max": 0.2})").find("subsidence_max"), std::string::npos);
  EXPECT_NE(err(R"({"erosion": {"rain": 1}})").find("erosion.rain"), std::string::npos);
  EXPECT_NE(err(R"({"erosion": {"steps": 2.5}})").find("x.json: erosion.steps = 2.5 must be a whole number"), std::string::npos);
  EXPECT_NE(err(R"({"erosion": {"m_area": 2}})").find("x.json: erosion.m_area = 2 is out of range; expected [0.1, 1]"), std::string::npos);
  EXPECT_NE(err(R"({"erosion": 3})").find("erosion must be a JSON object"), std::string::npos);
  EXPECT_NE(err(R"({"p_wilbur": 0.6, "p_mapgen4": 0.6})").find("add up to more than 1"), std::string::npos);
  EXPECT_NE(err(R"({"description": "kept", "cout": 3})").find("unknown key \"cout\""), std::string::npos);
  EXPECT_EQ(err(R"({"description": "a note for people"})"), "no error");
}

// The build library: two shards merged give the one-process build's manifest
// byte for byte, whatever the thread count; a resumed build reuses every pair;
// merge refuses a missing shard and stats count what was built.
TEST(DatasetBuild, ShardsMergedEqualOneBuildWhateverTheThreads) {
  const fs::path d = test::temp_dir("build");
  DatasetParams p;
  p.count = 6;
  p.size_px = 32;
  BuildOptions o;
  o.seed = 3;
  o.quiet = true;
  o.out = d / "one";
  o.threads = 2;
  const BuildResult one = build_dataset(p, o);
  EXPECT_EQ(one.pairs, 6u);
  EXPECT_EQ(one.reused, 0u);
  o.threads = 1;
  EXPECT_EQ(build_dataset(p, o).reused, 6u);  // resumed: every pair verified, none rewritten
  o.out = d / "sharded";
  o.shard = "1/2";
  EXPECT_EQ(build_dataset(p, o).pairs, 3u);
  test::expect_error_naming([&] { merge_dataset(o.out); }, "1 of 2 shard manifests");
  o.shard = "0/2";
  build_dataset(p, o);
  const MergeResult m = merge_dataset(o.out);
  EXPECT_EQ(m.shards, 2u);
  EXPECT_EQ(read_text(m.manifest), read_text(one.manifest));
  const nlohmann::json st = dataset_stats(o.out, 2, true);
  EXPECT_EQ(st["pairs"], 6);
  EXPECT_TRUE(fs::is_regular_file(o.out / "contact_sheet.png"));
  test::expect_error_naming([&] { parse_shard("2/2"); }, "2/2");
  fs::remove_all(d);
}

// Every file of a folder with its bytes: two builds are compared whole.
std::map<std::string, std::string> folder_bytes(const fs::path& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file() && e.path().extension() != ".lock")
      out[fs::relative(e.path(), dir).string()] = read_text(e.path());
  return out;
}

// The file (the shard, for webdataset) of the manifest's first pair.
fs::path first_listed_file(const fs::path& dataset) {
  const std::string manifest = read_text(dataset / "manifest.jsonl");
  const nlohmann::json r = nlohmann::json::parse(manifest.substr(0, manifest.find('\n')));
  return dataset / r.value("shard", r.value("ab", r.value("label", std::string())));
}

// The layouts for other tools: same bytes whatever the threads, a resumed
// build verifies and keeps every file, a damaged file is refused by name,
// and reefgen's trainer refuses the folder, naming the layout.
TEST(DatasetBuild, OtherLayoutsAreDeterministicAndResumable) {
  const fs::path d = test::temp_dir("layouts");
  DatasetParams p;
  p.count = 7;
  p.size_px = 32;
  p.val_fraction = 0.3;
  for (DatasetLayout layout : {DatasetLayout::Pix2pix, DatasetLayout::WebDataset, DatasetLayout::ImageFolder}) {
    SCOPED_TRACE(to_string(layout));
    BuildOptions o;
    o.seed = 5;
    o.quiet = true;
    o.layout = layout;
    o.tar_mb = 1;  // the smallest shards (71 samples of 32² each)
    o.out = d / (std::string(to_string(layout)) + "-2");
    o.threads = 2;
    EXPECT_EQ(build_dataset(p, o).reused, 0u);
    const auto two = folder_bytes(o.out);
    o.out = d / (std::string(to_string(layout)) + "-1");
    o.threads = 1;
    build_dataset(p, o);
    EXPECT_EQ(folder_bytes(o.out), two);
    const BuildResult again = build_dataset(p, o);
    EXPECT_EQ(again.reused, 7u);
    EXPECT_EQ(folder_bytes(o.out), two);
    test::expect_error_naming([&] { read_manifest(o.out, {}); }, std::string("the ") + to_string(layout) + " layout");
    // A damaged file: the resumed build names it.
    const fs::path victim = first_listed_file(o.out);
    ASSERT_TRUE(fs::exists(victim)) << victim;
    std::string bytes = read_text(victim);
    bytes[bytes.size() / 2] ^= 0x5A;
    write_text_atomic(victim, bytes);
    test::expect_error_naming([&] { build_dataset(p, o); }, victim.string() + " is corrupt");
  }
  BuildOptions o;
  o.out = d / "x";
  o.layout = DatasetLayout::Pix2pix;
  o.layers = true;
  test::expect_error_naming([&] { build_dataset(p, o); }, "--layers is for reefgen's layout");
  fs::remove_all(d);
}

// What a columnar loader (Hugging Face's imagefolder builder, pyarrow) infers
// from a JSON row: every key, nested, with its type.
std::string features_of(const nlohmann::json& v) {
  if (v.is_object()) {
    std::string s = "{";
    for (const auto& [k, x] : v.items()) s += k + ":" + features_of(x) + ",";
    return s + "}";
  }
  if (v.is_array()) return "[" + (v.empty() ? std::string() : features_of(v.front())) + "]";
  if (v.is_number_integer()) return "int";
  if (v.is_number()) return "float";
  return v.type_name();
}

// imagefolder's metadata.jsonl: every row of every split has the same
// features (Hugging Face refuses "different features"), though pairs differ
// in their augmentations (pasted, translated, affine or none; test pairs
// none); the augmentation record reads back from its string.
TEST(DatasetBuild, ImageFolderMetadataRowsShareTheirFeatures) {
  const fs::path d = test::temp_dir("imagefolder");
  DatasetParams p;
  p.count = 24;
  p.size_px = 32;
  p.val_fraction = 0.2;
  p.test_fraction = 0.2;
  p.p_paste = 0.5;
  p.p_translate = 0.5;
  BuildOptions o;
  o.quiet = true;
  o.layout = DatasetLayout::ImageFolder;
  o.out = d / "hf";
  build_dataset(p, o);
  std::set<std::string> features, augmentations;
  int rows = 0;
  for (const char* split : {"train", "val", "test"}) {
    std::istringstream lines(read_text(o.out / split / "metadata.jsonl"));
    for (std::string line; std::getline(lines, line); ++rows) {
      const nlohmann::json row = nlohmann::json::parse(line);
      features.insert(features_of(row));
      const nlohmann::json aug = nlohmann::json::parse(row["augmentation"].get<std::string>());
      augmentations.insert(features_of(aug));
    }
  }
  EXPECT_EQ(rows, 24);
  EXPECT_EQ(features.size(), 1u) << *features.begin() << "\n" << *features.rbegin();
  EXPECT_GE(augmentations.size(), 3u) << "the pairs' augmentations differ, so the test means something";
  fs::remove_all(d);
}

// A FIFO in a finished shard's place: one line naming it, no hang (it used
// to block in the comparison's read), and likewise in a per-pair layout.
TEST(DatasetBuild, AFifoInPlaceOfAFileIsRefusedWithoutHanging) {
  const fs::path d = test::temp_dir("fifo");
  DatasetParams p;
  p.count = 3;
  p.size_px = 32;
  for (DatasetLayout layout : {DatasetLayout::WebDataset, DatasetLayout::Pix2pix}) {
    SCOPED_TRACE(to_string(layout));
    BuildOptions o;
    o.quiet = true;
    o.layout = layout;
    o.out = d / to_string(layout);
    build_dataset(p, o);
    const fs::path victim = first_listed_file(o.out);
    fs::remove(victim);
    ASSERT_EQ(::mkfifo(victim.c_str(), 0644), 0);
    test::expect_error_naming([&] { build_dataset(p, o); }, victim.string());
  }
  fs::remove_all(d);
}

// Small tar: one shard holds what its size allows, the sample bound is an
// upper bound, and a member's header is ustar with a valid checksum.
TEST(DatasetFormats, TarNpyAndAlignedPng) {
  struct Bytes : ByteSink {
    std::string s;
    void put(const char* d, size_t n) override { s.append(d, n); }
  } sink;
  TarWriter tar(sink);
  tar.add("00000001.json", "{}");
  tar.finish();
  ASSERT_EQ(sink.s.size(), 512u * 4);  // header, one data block, two end blocks
  EXPECT_EQ(sink.s.substr(0, 13), "00000001.json");
  EXPECT_EQ(sink.s.substr(257, 5), "ustar");
  unsigned sum = 0;
  for (int i = 0; i < 512; ++i) sum += (i >= 148 && i < 156) ? ' ' : static_cast<unsigned char>(sink.s[i]);
  EXPECT_EQ(std::stoul(sink.s.substr(148, 6), nullptr, 8), sum);
  EXPECT_EQ(sink.s.substr(512, 2), "{}");

  cv::Mat1f h(3, 5);
  for (int i = 0; i < 15; ++i) h(i / 5, i % 5) = float(i) - 0.5f;
  const std::string npy = npy_bytes(h);
  EXPECT_EQ(npy.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  const size_t header = size_t(uint8_t(npy[8])) | size_t(uint8_t(npy[9])) << 8;
  EXPECT_EQ((10 + header) % 64, 0u);
  EXPECT_NE(npy.find("'shape': (3, 5)"), std::string::npos);
  ASSERT_EQ(npy.size(), 10 + header + 15 * sizeof(float));
  EXPECT_EQ(std::memcmp(npy.data() + 10 + header, h.ptr<float>(), 15 * sizeof(float)), 0);

  const Pair pr = island_pair(2, 48);
  const cv::Mat3b label = encode_labels(pr.label, pr.subsidence);
  const std::string png = aligned_png16(label, pr.height_m, -100, 560);
  const cv::Mat ab = cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(ab.type(), CV_16UC3);
  ASSERT_EQ(ab.size(), cv::Size(96, 48));
  cv::Mat a8;
  ab(cv::Rect(0, 0, 48, 48)).convertTo(a8, CV_8U, 1.0 / 257);
  EXPECT_TRUE(equal(a8, label));  // A: the label map exactly
  double worst = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 48; ++x) {
      const cv::Vec3w b = ab.at<cv::Vec3w>(y, 48 + x);
      EXPECT_TRUE(b[0] == b[1] && b[1] == b[2]);
      worst = std::max(worst, std::abs(-100 + b[0] / 65535.0 * 660 - pr.height_m(y, x)));
    }
  EXPECT_LE(worst, 660 / 65535.0 / 2 + 1e-4);  // half a 16-bit step: 5 mm
  EXPECT_GE(tar_sample_bound(32), 32u * 32 * 7);
}

// Every DatasetParams field, the nested erosion's too, survives the config
// file round trip.
TEST(Dataset, ParamsRoundTripEveryField) {
  test::expect_params_round_trip<DatasetParams>(
      [](const nlohmann::json& j) { return dataset_params_from_json(j, "round-trip.json"); });
}

// A manifest line nested 100,000 deep (it overflowed the stack in the
// recursive parse) or with a key twice is refused naming the manifest's
// line, as every JSON reefgen reads (files.hpp parse_json_checked).
TEST(DatasetBuild, ManifestLinesAreParsedWithTheDepthLimit) {
  const fs::path d = test::temp_dir("deep-manifest");
  DatasetParams p;
  p.count = 2;
  p.size_px = 32;
  BuildOptions o;
  o.seed = 3;
  o.quiet = true;
  o.out = d / "set";
  build_dataset(p, o);
  const fs::path manifest = o.out / "manifest.jsonl";
  const std::string good = read_text(manifest);
  const std::string rest = good.substr(good.find('\n') + 1);
  write_text_atomic(manifest, "{\"index\": " + std::string(100000, '[') + std::string(100000, ']') + "}\n" + rest);
  test::expect_error_naming([&] { read_manifest(o.out, {}); }, manifest.string() + ":1: JSON nested deeper than");
  write_text_atomic(manifest, "{\"index\": 0, \"index\": 1}\n" + rest);
  test::expect_error_naming([&] { read_manifest(o.out, {}); }, "key \"index\" appears twice");
  write_text_atomic(manifest, good);
  EXPECT_EQ(read_manifest(o.out, {}).size(), 2u);
}
