#include "reefgen/infer/variation.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/terrain/erosion.hpp"
#include "reefgen/terrain/noise.hpp"

namespace reefgen::infer {

namespace {
// (a⁻⁸ + b⁻⁸)^(−1/8): below both, within 9 % of the smaller, and smooth
// where they cross (a hard min turns there); of two 1-Lipschitz fields it
// is 1-Lipschitz (its gradient's weights sum to ≤ 1). Powers by squaring:
// one call per land cell.
float soft_minimum(float a, float b) {
  if (!(a > 0.f) || !(b > 0.f)) return std::max(0.f, std::min(a, b));
  const double m = std::min(a, b), ra = m / a, rb = m / b;
  const double ra2 = ra * ra, rb2 = rb * rb, ra4 = ra2 * ra2, rb4 = rb2 * rb2;
  return float(m / std::sqrt(std::sqrt(std::sqrt(ra4 * ra4 + rb4 * rb4))));
}
}  // namespace

cv::Mat1f creaseless_distance(const cv::Mat1f& dist_px) {
  cv::Mat1f out = dist_px.clone();
  cv::Mat1i comp, stats;
  cv::Mat1d centroids;
  const int n = cv::connectedComponentsWithStats(dist_px > 0.f, comp, stats, centroids, 8, CV_32S);
  for (int c = 1; c < n; ++c) {
    const cv::Rect box(stats(c, cv::CC_STAT_LEFT), stats(c, cv::CC_STAT_TOP), stats(c, cv::CC_STAT_WIDTH),
                       stats(c, cv::CC_STAT_HEIGHT));
    double widest = 0;
    cv::minMaxLoc(dist_px(box), nullptr, &widest, nullptr, nullptr, comp(box) == c);
    // Land without sea on the canvas reads an unbounded distance: the
    // blur is held to the canvas's own size.
    const double sigma = kRerollCreaseShare * std::min(widest, double(std::max(dist_px.rows, dist_px.cols)));
    if (sigma < 0.5) continue;
    // The blur's reach around the island: 3σ.
    const int m = int(std::ceil(3 * sigma));
    const cv::Rect roi = cv::Rect(box.x - m, box.y - m, box.width + 2 * m, box.height + 2 * m) &
                         cv::Rect(0, 0, dist_px.cols, dist_px.rows);
    cv::Mat1f smooth;
    cv::GaussianBlur(dist_px(roi), smooth, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
    for (int y = box.y; y < box.y + box.height; ++y)
      for (int x = box.x; x < box.x + box.width; ++x)
        if (comp(y, x) == c) out(y, x) = soft_minimum(out(y, x), smooth(y - roi.y, x - roi.x));
  }
  return out;
}

cv::Mat1f reroll_land(const cv::Mat1f& height_m, double metres_per_px, uint64_t seed, double variation) {
  if (!(variation >= 0 && variation <= 1)) throw Error("reroll: variation must be in [0, 1]");
  if (!(metres_per_px > 0)) throw Error("reroll: the cell size must be positive");
  cv::Mat1f out = height_m.clone();
  if (variation == 0 || height_m.empty()) return out;
  const cv::Mat1b land = height_m > 0.f;
  cv::Mat1f dist;
  cv::distanceTransform(land, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  dist = creaseless_distance(dist);
  const terrain::GradientNoise2 nx(derive_seed(seed, 0, "reroll-x")), ny(derive_seed(seed, 0, "reroll-y"));
  const float features_per_px = float(metres_per_px / kRerollFeatureM);
  const float k = float(variation * kRerollShiftShare);
  // Each seed leans the massif its own way, seed n at n golden angles
  // (137.5°) from seed 0, so consecutive seeds (the studio's Re-roll) lean
  // far apart; the noise bends the lean across the island.
  const double turn = std::fmod(double(seed % 1000003u) * kGoldenRatioConjugate, 1.0);
  const float lean_u = float(kRerollLean * std::cos(2 * M_PI * turn)), lean_v = float(kRerollLean * std::sin(2 * M_PI * turn));
  cv::Mat1f mx(height_m.size()), my(height_m.size());
  for (int y = 0; y < height_m.rows; ++y)
    for (int x = 0; x < height_m.cols; ++x) {
      // fBm of two octaves is mostly within ±0.6; the sum is held inside
      // the unit disc (|shift| < distance).
      float u = lean_u + float(kRerollBend) * nx.fbm(float(x) * features_per_px, float(y) * features_per_px, 2);
      float v = lean_v + float(kRerollBend) * ny.fbm(float(x) * features_per_px, float(y) * features_per_px, 2);
      const float len = std::hypot(u, v);
      if (len > 1.f) u /= len, v /= len;
      const float d = k * dist(y, x);
      mx(y, x) = float(x) + d * u;
      my(y, x) = float(y) + d * v;
    }
  cv::Mat1f warped;
  cv::remap(height_m, warped, mx, my, cv::INTER_CUBIC, cv::BORDER_REPLICATE);
  // The cubic's taps next to the coast can reach a sea cell: land keeps the
  // land's floor (or its own height, if lower).
  for (int y = 0; y < height_m.rows; ++y)
    for (int x = 0; x < height_m.cols; ++x)
      if (land(y, x)) out(y, x) = std::max(warped(y, x), std::min(height_m(y, x), terrain::kLandFloorM));
  return out;
}

Rerolled reroll_for_amplify(const cv::Mat1f& height_m, double metres_per_px, uint64_t seed, double variation,
                            const AmplifyParams& params) {
  Rerolled r{reroll_land(height_m, metres_per_px, seed, variation), params};
  if (variation > 0) r.params.erode_at_model_side = true;
  return r;
}

}  // namespace reefgen::infer
