#include "reefgen/infer/reef_finish.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/ramp.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/rows.hpp"
#include "reefgen/terrain/noise.hpp"
#include "reefgen/terrain/patch_reefs.hpp"

#include "regions.hpp"

namespace reefgen::infer {

namespace {

// A reef without lagoon or land behind it (a bank) has no back edge: its t
// is taken as if land lay this far in, so its top still has a crest and a
// flat (reef flats are 850 ± 817 m wide, docs/REEF.md).
constexpr double kBankBackM = 2000;
// Motu stand on the ring: at least this share of the cells around a painted
// islet is reef (the rest lagoon, passes, other islets).
constexpr double kMotuReefShare = 0.5;
// The features of the reef top's irregularity, metres (coral heads, rubble).
constexpr float kTopFeatureM = 60.f;
// Land on the reef band is lowered awash from this far off painted land
// (island or beach), fully from the second distance, metres (about one and
// three model cells): a fringing reef keeps its shore.
constexpr float kShoreEaseFromM = 25.f, kShoreEaseToM = 70.f;
// Just off the painted band (the blurred reef mask between 0 and 1) land is
// lowered fully from this share of the mask, and on the painted open sea
// fully: partly lowered or left, beads at the fore reef's edge stood as
// specks of land up to 5 m high beside the drop (~320 of them, 185 on
// painted open sea, on an 8193² archipelago's reefs).
constexpr float kBandEdgeReef = 0.2f;
// Blur of the painted zones (t, the reef mask), model cells.
constexpr double kZoneBlurPx = 1.0;
// Blur of a zone field after its upsampling, source cells.
constexpr double kZoneUpsampleBlur = 0.5;
// px: above this σ the zone blur runs on a coarser grid (resized()).
constexpr double kZoneWorkSigmaPx = 4;
// A motu's shore: its outline wanders by this much with the noise, its beach
// rises from the reef flat to +0.3 m over kMotuBeachM seaward of the painted
// edge, then the berm over kMotuBermM inland (beaches a few tens of metres wide).
constexpr float kMotuOutlineWanderM = 25.f;
constexpr float kMotuBeachM = 30.f;
constexpr float kMotuBermM = 40.f;
constexpr float kMotuShoreM = 0.3f;
// Below the beach the islet's apron keeps descending at this slope (m/m,
// ~27°, sand and rubble at rest) until it meets the model's floor: no cliff.
constexpr float kMotuApronSlope = 0.5f;
// Beyond this distance from a painted islet nothing is motu, metres: the
// apron has reached -48 m by then, below any lagoon floor around it.
constexpr float kMotuReachM = 150.f;
// A motu's inside (docs/REEF.md "Motu"): behind the berm a flat at its
// height with swales and low beach ridges of ±kMotuSwaleM over features
// kMotuSwaleFeatureM apart, eased in over kMotuInteriorM. Sand drains into
// the ground, not in streams, so nothing grades it towards the sea, and no
// hollow is deeper than kPitDepthM (0.5 m), from which the pit draining would
// breach it. (A storm ridge higher than the flat behind it makes a level
// crest line along the whole shore: the straight flat strip the realism
// report counts as a channel.)
constexpr float kMotuInteriorM = 30.f;
constexpr float kMotuSwaleM = 0.2f;
constexpr float kMotuSwaleFeatureM = 25.f;

// Height of a motu sd_m metres inside its wandered edge (sd_m ≥ 0): the
// beach's top at the edge, the berm kMotuBermM in, then the interior.
// n: the shore noise (the berm's height varies with it), swale: noise in [-1, 1].
float motu_inside_m(float sd_m, float n, float swale, const PaintedReefParams& p) {
  const float berm = float(p.motu_height_m) * (1 + 0.2f * n);
  if (sd_m < kMotuBermM) return kMotuShoreM + (berm - kMotuShoreM) * ramp(0, kMotuBermM, sd_m);
  return berm + kMotuSwaleM * swale * ramp(kMotuBermM, kMotuBermM + kMotuInteriorM, sd_m);
}

// The painted islets small enough to be motu and ringed by reef.
cv::Mat1b motu_mask(const cv::Mat1b& label, double cell_m, const PaintedReefParams& p) {
  cv::Mat1i comp;
  const cv::Mat1b land = (label == kIsland) | (label == kBeach);
  const int n = cv::connectedComponents(land, comp, 8, CV_32S);
  // Half the width of each islet: its deepest cell's distance to the water.
  cv::Mat1f inland;
  cv::distanceTransform(land, inland, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  std::vector<float> half_width(size_t(n), 0.f);
  std::vector<int64_t> area(size_t(n), 0), reef(size_t(n), 0), around(size_t(n), 0);
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < label.cols; ++x) {
      const int c = comp(y, x);
      if (c == 0) continue;
      ++area[size_t(c)];
      half_width[size_t(c)] = std::max(half_width[size_t(c)], inland(y, x));
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int yy = y + dy, xx = x + dx;
          if (yy < 0 || xx < 0 || yy >= label.rows || xx >= label.cols || landlike(label(yy, xx))) continue;
          ++around[size_t(c)];
          reef[size_t(c)] += label(yy, xx) == kReef;
        }
    }
  std::vector<uint8_t> is_motu(size_t(n), 0);
  for (size_t c = 1; c < size_t(n); ++c)
    is_motu[c] = double(area[c]) * cell_m * cell_m <= p.motu_max_area_m2 &&
                 2.0 * half_width[c] * cell_m <= p.motu_max_width_m + cell_m && around[c] > 0 &&
                 double(reef[c]) >= kMotuReefShare * double(around[c]);
  cv::Mat1b motu(label.size(), uint8_t(0));
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < label.cols; ++x) motu(y, x) = is_motu[size_t(comp(y, x))] ? 255 : 0;
  return motu;
}

// Signed distance (model cells) to the painted islets' edge, > 0 inside,
// within ±reach_px; the edge lies half a cell outside the painted cells.
cv::Mat1f motu_signed_distance(const cv::Mat1b& motu, float reach_px) {
  const cv::Mat1f in = distance_to(cv::Mat1b(motu == 0), reach_px + 1);
  const cv::Mat1f out = distance_to(motu, reach_px + 1);
  cv::Mat1f sd(motu.size());
  for (int y = 0; y < motu.rows; ++y)
    for (int x = 0; x < motu.cols; ++x)
      sd(y, x) = std::clamp(motu(y, x) ? in(y, x) - 0.5f : 0.5f - out(y, x), -reach_px, reach_px);
  return sd;
}

// A zone field at the output side: upsampled bilinear, then blurred over
// half a source cell. Bilinear weights kink at every source cell's edge, and
// a reef top or a knoll eased by them showed the model's 23.4 m grid as
// facets at 1:1 (bicubic kinks there too: its curvature is discontinuous).
// Where that blur's σ passes kZoneWorkSigmaPx (4097² and up from a 256²
// sketch) it runs on a grid where σ spans that many cells, read back
// bilinearly: at 8192² σ is 16 px, a 129-tap kernel over 67 M pixels, and a
// field blurred over σ is within ~0.2 % of its range of its bilinear read
// back from cells σ/4 apart (h²/8 · max|f''|, |f''| ≤ 0.24 range/σ²).
cv::Mat1f resized(const cv::Mat1f& m, int side) {
  if (m.cols == side) return m.clone();
  cv::Mat1f out;
  if (side <= 2 * m.cols) {
    cv::resize(m, out, cv::Size(side, side), 0, 0, side > m.cols ? cv::INTER_LINEAR : cv::INTER_AREA);
    return out;
  }
  const double sigma = kZoneUpsampleBlur * side / m.cols;
  const int work = sigma > kZoneWorkSigmaPx ? int(std::ceil(side * kZoneWorkSigmaPx / sigma)) : side;
  cv::resize(m, out, cv::Size(work, work), 0, 0, cv::INTER_LINEAR);
  const double work_sigma = sigma * work / side;
  cv::GaussianBlur(out, out, cv::Size(0, 0), work_sigma, work_sigma, cv::BORDER_REPLICATE);
  if (work != side) cv::resize(out, out, cv::Size(side, side), 0, 0, cv::INTER_LINEAR);
  return out;
}

// The motu's signed distance (label cells) at side N, blurred a little: the
// painted edge is a staircase of model cells.
cv::Mat1f motu_distance_at(const cv::Mat1b& motu_s, float reach_px, int N) {
  cv::Mat1f sd = motu_signed_distance(motu_s, reach_px);
  cv::GaussianBlur(sd, sd, cv::Size(0, 0), 0.7, 0.7, cv::BORDER_REPLICATE);
  return resized(sd, N);
}

// Irregular islets, not the painted disc: the shore (sd_raw metres from the
// painted edge, n the shore noise) wanders with the noise; the apron below
// it does not (it would be as rough as the wander).
float wandered_m(float sd_raw, float n) {
  return sd_raw + kMotuOutlineWanderM * n * ramp(-3 * kMotuBeachM, -kMotuBeachM, sd_raw);
}

}  // namespace

cv::Mat1f reef_position(const cv::Mat1b& label, const PaintedReefParams& p, double world_size_m, cv::Mat1b& motu) {
  if (label.empty() || label.rows != label.cols) throw Error("painted reef: the label map must be square");
  const double cell_m = world_size_m / label.cols;
  motu = motu_mask(label, cell_m, p);
  const cv::Mat1b sea = label == kAbyss;
  const cv::Mat1b back = ((label == kLagoon) | (label == kIsland) | (label == kBeach)) & ~motu;
  const float big = float(label.cols) * 2.f;
  const cv::Mat1f d_sea = distance_to(sea, big);
  const cv::Mat1f d_back = distance_to(back, float(kBankBackM / cell_m));
  cv::Mat1f t(label.size());
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < label.cols; ++x) {
      const float s = d_sea(y, x), b = d_back(y, x);
      // No open sea on the canvas: nothing is a fore reef, the reef is all back.
      t(y, x) = s >= big ? 1.f : s / std::max(s + b, 1e-6f);
    }
  return t;
}

// Per cell at the output side, with t and the masks interpolated:
//   w     = ramp(crest_begin − 0.1, crest_begin, t) · (1 − ramp(flat_end, flat_end + 0.1, t)) · reef
//   top   = crest_m → flat_m across t 0.3–0.36, + top_relief_m · noise, ≤ −5 cm
//   h    += w · max(0, top − h), and where h > top,
//   h    += w_down · (top − h),  w_down = reef band, eased out next to painted land
// and on motu (sd: the signed distance to the painted islet's edge, metres,
// wandering with the noise) h = max(h, a beach from the flat to +0.3 m at the
// edge, then a berm of motu_height_m).
void finish_painted_reef(cv::Mat1f& h, const cv::Mat1b& label, double world_size_m, uint64_t seed,
                         const PaintedReefParams& p) {
  if (h.empty() || h.rows != h.cols) throw Error("painted reef: the height field must be square");
  cv::Mat1b motu_s;
  const cv::Mat1f t_s = reef_position(label, p, world_size_m, motu_s);
  cv::Mat1f reef_s;
  cv::Mat1f((label == kReef) | motu_s).convertTo(reef_s, CV_32F, 1.0 / 255);
  const bool any_motu = cv::countNonZero(motu_s) > 0;
  const float label_cell_m = float(world_size_m / label.cols);
  const float reach_px = std::max(2.f, kMotuReachM / label_cell_m);
  // Blurred over a model cell: the painted edges are pixel staircases, and a
  // distance ratio over a staircase kinks wherever the staircase steps.
  cv::Mat1f t_smooth;
  cv::GaussianBlur(t_s, t_smooth, cv::Size(0, 0), kZoneBlurPx, kZoneBlurPx, cv::BORDER_REPLICATE);
  cv::GaussianBlur(reef_s, reef_s, cv::Size(0, 0), kZoneBlurPx, kZoneBlurPx, cv::BORDER_REPLICATE);
  const int N = h.cols;
  const cv::Mat1f t = resized(t_smooth, N), reef = resized(reef_s, N);
  const cv::Mat1f sd = any_motu ? motu_distance_at(motu_s, reach_px, N) : cv::Mat1f(N, N, -reach_px);
  // The painted reef band itself (not eased): land on it is lowered fully,
  // easing out next to painted land (kShoreEase*), where a fringing reef
  // meets its shore.
  cv::Mat1b reef_band, open_sea;
  cv::resize(cv::Mat1b(label == kReef), reef_band, cv::Size(N, N), 0, 0, cv::INTER_NEAREST);
  cv::resize(cv::Mat1b(label == kAbyss), open_sea, cv::Size(N, N), 0, 0, cv::INTER_NEAREST);
  cv::Mat1f from_land;
  cv::distanceTransform(cv::Mat1b((label != kIsland) & (label != kBeach)), from_land, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  from_land = resized(from_land, N);
  const terrain::GradientNoise2 noise(derive_seed(seed, 0, "painted-reef-top"));
  const float per_feature = float(world_size_m / N) / kTopFeatureM;
  const float crest = float(p.crest_m), flat = float(p.flat_m);
  for_each_row(N, [&](int y) {
    for (int x = 0; x < N; ++x) {
      const float tt = t(y, x);
      const float w = ramp(p.crest_begin - 0.1, p.crest_begin, tt) * (1 - ramp(p.flat_end, p.flat_end + 0.1, tt)) * reef(y, x);
      const bool near_motu = sd(y, x) > -reach_px + 0.5f;
      // Land on the reef band is lowered to the top (eased off painted
      // land, motu included), also seaward of the crest where w eases in and
      // beside a pass, which is painted lagoon.
      const float w_down = ramp(kShoreEaseFromM, kShoreEaseToM, from_land(y, x) * label_cell_m) *
                           (reef_band(y, x) || open_sea(y, x) ? 1.f : std::min(1.f, reef(y, x) / kBandEdgeReef));
      const bool fore_reef = tt < p.crest_begin && reef(y, x) > 0;
      if (w <= 0 && w_down <= 0 && !near_motu && !fore_reef) continue;
      const float n = noise.fbm(float(x) * per_feature, float(y) * per_feature, 3);
      const float sd_raw = sd(y, x) * label_cell_m;
      const float sd_m = wandered_m(sd_raw, n);
      // Faded in from the edge of its reach, so the apron ends without a step.
      // Seaward of the crest the apron gives way to the fore reef.
      const float apron_w = sd_m >= 0 ? 1.f : ramp(p.crest_begin - 0.1, p.crest_begin, tt);
      const float reach_w = apron_w * ramp(-reach_px * label_cell_m, -reach_px * label_cell_m + kMotuBermM, sd_raw);
      const bool on_motu = near_motu;
      float& z = h(y, x);
      // The fore reef: from the crest down to fore_edge_m at the band's
      // seaward edge (t 0), linearly across it; only lowering.
      if (fore_reef) {
        const float out = 1.f - tt / float(p.crest_begin);
        const float fore = crest + (float(p.fore_edge_m) - crest) * out;
        if (z > fore) z += reef(y, x) * (fore - z);
      }
      if (w > 0 || w_down > 0) {
        const float top = std::min(crest + (flat - crest) * ramp(0.3, 0.36, tt) + float(p.top_relief_m) * n, -0.05f);
        z += w * std::max(0.f, top - z);
        // The crest is awash, as the generator builds it: the network
        // answers a painted crest with cells just above and below the sea a
        // model cell or two apart, which amplified became a chain of land
        // beads (0.3–1.7 m, ~44 m apart) along the crest at 4097². Beside a
        // motu too (w_down eases out next to it as next to any painted land;
        // beads kept within its reach stood as slivers of land along it);
        // the motu's own profile is raised after.
        if (z > top) z += w_down * (top - z);
      }
      if (on_motu) {
        const float lv = sd_m < -kMotuBeachM ? flat - kMotuApronSlope * (-kMotuBeachM - sd_m)
                         : sd_m < 0 ? flat + (kMotuShoreM - flat) * ramp(-kMotuBeachM, 0, sd_m)
                                    : motu_inside_m(std::min(sd_m, kMotuBermM), n, 0, p);
        z += reach_w * std::max(0.f, lv - z);
      }
    }
  });
}

void settle_motu(cv::Mat1f& h, const cv::Mat1b& label, double world_size_m, uint64_t seed,
                 const PaintedReefParams& p) {
  if (h.empty() || h.rows != h.cols || label.empty() || label.rows != label.cols)
    throw Error("painted motu: the height field and the label map must be square");
  const float label_cell_m = float(world_size_m / label.cols);
  const cv::Mat1b motu_s = motu_mask(label, label_cell_m, p);
  if (cv::countNonZero(motu_s) == 0) return;
  const float reach_px = std::max(2.f, kMotuReachM / label_cell_m);
  const int N = h.cols;
  const cv::Mat1f sd = motu_distance_at(motu_s, reach_px, N);
  // The shore noise of finish_painted_reef (the same outline and berm).
  const terrain::GradientNoise2 noise(derive_seed(seed, 0, "painted-reef-top"));
  const terrain::GradientNoise2 swales(derive_seed(seed, 0, "motu-swales"));
  const float cell_m = float(world_size_m / N);
  const float per_feature = cell_m / kTopFeatureM, per_swale = cell_m / kMotuSwaleFeatureM;
  for_each_row(N, [&](int y) {
    for (int x = 0; x < N; ++x) {
      const float sd_raw = sd(y, x) * label_cell_m;
      // The wander moves the edge by at most its amplitude.
      if (sd_raw <= -kMotuOutlineWanderM) continue;
      const float n = noise.fbm(float(x) * per_feature, float(y) * per_feature, 3);
      const float sd_m = wandered_m(sd_raw, n);
      if (sd_m <= 0) continue;
      const float swale = std::clamp(swales.fbm(float(x) * per_swale, float(y) * per_swale, 2), -1.f, 1.f);
      h(y, x) = std::min(h(y, x), motu_inside_m(sd_m, n, swale, p));
    }
  });
}

namespace {
// A lagoon cell is floor below this, metres: shallower is the reef flat,
// the shore or a knoll the network already drew.
constexpr float kLagoonFloorM = -2.f;
}  // namespace

void grow_painted_patch_reefs(cv::Mat1f& h, const cv::Mat1b& label, double world_size_m, uint64_t seed,
                              const PaintedLagoonParams& p) {
  if (p.patch_reefs <= 0 || h.empty()) return;
  const int N = h.cols;
  // The painted lagoon at this side, eased in over a model cell from its edges.
  cv::Mat1f lagoon_s;
  cv::Mat1f(label == kLagoon).convertTo(lagoon_s, CV_32F, 1.0 / 255);
  cv::GaussianBlur(lagoon_s, lagoon_s, cv::Size(0, 0), kZoneBlurPx, kZoneBlurPx, cv::BORDER_REPLICATE);
  const cv::Mat1f lagoon = resized(lagoon_s, N);
  const terrain::GradientNoise2 noise(derive_seed(seed, 0, "painted-patch-reefs"));
  const double cell_m = world_size_m / N;
  for_each_row(N, [&](int y) {
    for (int x = 0; x < N; ++x) {
      const float w = std::clamp(2.f * lagoon(y, x) - 1.f, 0.f, 1.f);
      if (w <= 0 || !(h(y, x) < kLagoonFloorM)) continue;
      const float knoll = std::max(h(y, x), terrain::patch_reef_m(noise, x * cell_m, y * cell_m, -h(y, x), p.patch_reefs));
      h(y, x) = float(h(y, x) + w * (knoll - h(y, x)));
    }
  });
}

}  // namespace reefgen::infer
