#include "reefgen/infer/variation.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/terrain/erosion.hpp"
#include "reefgen/terrain/noise.hpp"

namespace reefgen::infer {

cv::Mat1f reroll_land(const cv::Mat1f& height_m, double metres_per_px, uint64_t seed, double variation) {
  if (!(variation >= 0 && variation <= 1)) throw Error("reroll: variation must be in [0, 1]");
  if (!(metres_per_px > 0)) throw Error("reroll: the cell size must be positive");
  cv::Mat1f out = height_m.clone();
  if (variation == 0 || height_m.empty()) return out;
  const cv::Mat1b land = height_m > 0.f;
  cv::Mat1f dist;
  cv::distanceTransform(land, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  const terrain::GradientNoise2 nx(derive_seed(seed, 0, "reroll-x")), ny(derive_seed(seed, 0, "reroll-y"));
  const float features_per_px = float(metres_per_px / kRerollFeatureM);
  const float k = float(variation * kRerollShiftShare);
  cv::Mat1f mx(height_m.size()), my(height_m.size());
  for (int y = 0; y < height_m.rows; ++y)
    for (int x = 0; x < height_m.cols; ++x) {
      // fBm of two octaves is mostly within ±0.6: stretched to use the
      // whole unit disc, then held inside it (|shift| < distance).
      float u = 1.6f * nx.fbm(float(x) * features_per_px, float(y) * features_per_px, 2);
      float v = 1.6f * ny.fbm(float(x) * features_per_px, float(y) * features_per_px, 2);
      const float len = std::hypot(u, v);
      if (len > 1.f) u /= len, v /= len;
      const float d = k * dist(y, x);
      mx(y, x) = float(x) + d * u;
      my(y, x) = float(y) + d * v;
    }
  cv::Mat1f warped;
  cv::remap(height_m, warped, mx, my, cv::INTER_CUBIC, cv::BORDER_REPLICATE);
  // Bilinear taps next to the coast can reach a sea cell: land keeps the
  // land's floor (or its own height, if lower).
  for (int y = 0; y < height_m.rows; ++y)
    for (int x = 0; x < height_m.cols; ++x)
      if (land(y, x)) out(y, x) = std::max(warped(y, x), std::min(height_m(y, x), terrain::kLandFloorM));
  return out;
}

}  // namespace reefgen::infer
