#include "reefgen/procgen/erosion.hpp"

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/terrain/pits.hpp"

namespace reefgen::procgen {

using namespace reefgen::terrain;

cv::Mat1f erode_island(const cv::Mat1f& h_N, const cv::Mat1f& rho_N, double world_size_m, uint64_t seed,
                       const ErosionParams& p) {
  if (!p.enabled) return h_N.clone();
  if (h_N.empty() || h_N.size() != rho_N.size() || h_N.rows != h_N.cols)
    throw Error("erode: height and resistance must be square and of the same size");
  const int N = h_N.cols, B = std::min(N, p.base_px);
  cv::Mat1f base = resampled(h_N, B, cv::INTER_AREA);
  erode_level(base, erodibility_map(resampled(rho_N, B, cv::INTER_AREA), seed, p), world_size_m / B, p.steps,
              p.duration_yr, p);
  // Detail of level L = what the render holds at L beyond the level before it.
  cv::Mat1f prev_down = resampled(h_N, B, cv::INTER_AREA);
  auto detail = [&](int L, const cv::Mat1f& up) {
    cv::Mat1f down = resampled(h_N, L, cv::INTER_AREA);
    cv::Mat1f d = down - resampled(prev_down, L, cv::INTER_CUBIC);
    prev_down = std::move(down);
    return cv::Mat1f(d + fractal_detail(L, up, world_size_m, seed));
  };
  cv::Mat1f out = refine_heights(base, h_N, rho_N, world_size_m, seed, p, detail);
  drain_pits(out, kPitDepthM, float(p.pit_breach_m));
  return out;
}

}  // namespace reefgen::procgen
