#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/infer/amplify.hpp"
#include "reefgen/terrain/pits.hpp"

namespace reefgen::infer {

using namespace reefgen::terrain;

namespace {
constexpr float kBandDiffusion = 0.15f;

// Where the centres of rows [y0, y1) of a side-N grid fall on a side-M
// level's cells, as cv::resize maps half-pixel centres: cv::remap's maps.
void centre_maps(int M, int N, int y0, int y1, cv::Mat1f& mx, cv::Mat1f& my) {
  const float scale = float(M) / float(N);
  mx.create(y1 - y0, N);
  my.create(y1 - y0, N);
  for (int y = 0; y < y1 - y0; ++y)
    for (int x = 0; x < N; ++x) {
      mx(y, x) = (float(x) + 0.5f) * scale - 0.5f;
      my(y, x) = (float(y0 + y) + 0.5f) * scale - 0.5f;
    }
}

// The bicubic sample of `level` on rows [y0, y1) of the side-N grid, blurred
// as upsampled_level blurs a whole level (terrain/erosion.hpp): the rows
// the blur reads beyond the band are sampled too, and the canvas's own edges
// replicated as the whole level's blur replicates them.
cv::Mat1f bicubic_rows(const cv::Mat1f& level, int N, int y0, int y1, double sigma_cells) {
  const int M = level.cols;
  const double sigma_px = N > M ? sigma_cells * N / M : 0.0;
  const int reach = sigma_px > 0 ? int(std::ceil(4 * sigma_px)) : 0;
  const int a = std::max(0, y0 - reach), b = std::min(N, y1 + reach);
  cv::Mat1f mx, my, up;
  centre_maps(M, N, a, b, mx, my);
  cv::remap(level, up, mx, my, cv::INTER_CUBIC, cv::BORDER_REPLICATE);
  if (sigma_px > 0) cv::GaussianBlur(up, up, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  return up.rowRange(y0 - a, y1 - a).clone();
}

// Rows [y0, y1) of `fine` (side N): `level` (side M) sampled bicubically (bicubic_rows) at
// each cell's centre, as cv::resize maps half-pixel centres, plus the level's
// fractal detail on land.
cv::Mat1f band_of(const cv::Mat1f& level, int N, int y0, int y1, double world_size_m, uint64_t seed,
                  const ErosionParams& p, const cv::Mat1f& rugged_m) {
  const int rows = y1 - y0;
  cv::Mat1f mx, my;
  centre_maps(level.cols, N, y0, y1, mx, my);
  cv::Mat1f up = bicubic_rows(level, N, y0, y1, p.refine_upsample_sigma), lin;
  // The coast is where the bilinear sample crosses 0 m, not the bicubic one:
  // next to the fore reef's drop the bicubic overshoots a crest at −0.1 m
  // above the sea, and the land's floor below made each overshoot a speck of
  // land (287 specks of ≤ 20 cells along the crests of an 8193² world).
  cv::remap(level, lin, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  cv::Mat1f d = fractal_detail(N, up, world_size_m, seed, {0, y0});
  // The style's detail share (amplify.hpp), from the style at the level
  // below (rugged_m, side M) sampled like the heights: a band needs no N² map.
  if (!rugged_m.empty()) {
    cv::Mat1f rb;
    cv::remap(rugged_m, rb, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    d = d.mul(kSmoothDetailShare + (1.f - kSmoothDetailShare) * rb);
  }
  const float s = float(p.refine_detail_scale);
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < N; ++x) {
      if (lin(y, x) > 0)
        up(y, x) = std::max(up(y, x) + s * d(y, x), kLandFloorM);
      else if (up(y, x) > 0)
        up(y, x) = lin(y, x);
    }
  // One explicit diffusion step on land (h += k·∇²h, k = kBandDiffusion):
  // the level below was eroded and diffused, this one is not.
  cv::Mat1f lap;
  cv::Laplacian(up, lap, CV_32F, 1, 1.0, 0.0, cv::BORDER_REPLICATE);
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < N; ++x)
      if (up(y, x) > 0) up(y, x) = std::max(up(y, x) + kBandDiffusion * lap(y, x), kLandFloorM);
  return up;
}
}  // namespace

namespace {
// A world that is not square: its last row or column repeated at the bottom
// or right up to a square (with the sea there, the bicubic upsampling pulled
// the world's last rows 57 m down: a seam score of 13), amplified with
// `size` for its longer side, and cropped back.
cv::Mat1f amplify_oblong(const cv::Mat1f& coarse_m, const cv::Mat1b& label, int size, double world_size_m,
                         uint64_t seed, const AmplifyParams& p, const std::function<void(int, int)>& progress,
                         const WorldBands& wb, const cv::Mat1b& ruggedness) {
  const int W = coarse_m.cols, H = coarse_m.rows, S = std::max(W, H);
  cv::Mat1f sq;
  cv::copyMakeBorder(coarse_m, sq, 0, S - H, 0, S - W, cv::BORDER_REPLICATE);
  cv::Mat1b l;
  cv::resize(label, l, coarse_m.size(), 0, 0, cv::INTER_NEAREST);
  cv::copyMakeBorder(l, l, 0, S - H, 0, S - W, cv::BORDER_REPLICATE);
  cv::Mat1b r;
  if (!ruggedness.empty()) {
    cv::resize(ruggedness, r, coarse_m.size(), 0, 0, cv::INTER_AREA);
    cv::copyMakeBorder(r, r, 0, S - H, 0, S - W, cv::BORDER_REPLICATE);
  }
  const cv::Mat1f out = amplify_world(sq, l, size, world_size_m * S / W, seed, p, progress, wb, r);
  const cv::Size keep(int(std::lround(double(W) * size / S)), int(std::lround(double(H) * size / S)));
  return out(cv::Rect(cv::Point(0, 0), keep)).clone();
}
}  // namespace

cv::Mat1f amplify_world(const cv::Mat1f& coarse_m, const cv::Mat1b& label, int size, double world_size_m,
                        uint64_t seed, const AmplifyParams& p, const std::function<void(int, int)>& progress,
                        const WorldBands& wb, const cv::Mat1b& ruggedness) {
  if (coarse_m.empty()) throw Error("world: nothing to amplify");
  const int S = std::max(coarse_m.rows, coarse_m.cols);
  if (size < S || size > kMaxWorldSidePx)
    throw Error("world: --size must be in [" + std::to_string(S) + ", " + std::to_string(kMaxWorldSidePx) +
                "] for this sketch");
  if (coarse_m.rows != coarse_m.cols)
    return amplify_oblong(coarse_m, label, size, world_size_m, seed, p, progress, wb, ruggedness);
  auto at = [&](int side) {
    cv::Mat1b l;
    cv::resize(label, l, cv::Size(side, side), 0, 0, cv::INTER_NEAREST);
    return l;
  };
  if (size <= wb.whole_max_px) return amplify_heights(coarse_m, at(size), world_size_m, seed, p, true, ruggedness);
  const std::vector<int> levels = refinement_levels(coarse_m.cols, size);
  const int M = levels.size() >= 2 ? levels[levels.size() - 2] : coarse_m.cols;
  // Its low land's relief comes after each band's draining, not here.
  const cv::Mat1f level = amplify_heights(coarse_m, at(M), world_size_m, seed, p, false, ruggedness);
  const cv::Mat1f rugged_m = ruggedness_at(ruggedness, M, world_size_m);
  cv::Mat1f out(size, size);
  const int bands = (size + wb.rows_px - 1) / wb.rows_px;
  for (int b = 0; b < bands; ++b) {
    const int y0 = b * wb.rows_px, y1 = std::min(size, y0 + wb.rows_px);
    const int h0 = std::max(0, y0 - wb.halo_px), h1 = std::min(size, y1 + wb.halo_px);
    cv::Mat1f band = band_of(level, size, h0, h1, world_size_m, seed, p.erosion, rugged_m);
    drain_pits(band, kPitDepthM, float(p.erosion.pit_breach_m), world_size_m / size);
    add_lowland_relief(band, h0, seed);
    band(cv::Rect(0, y0 - h0, size, y1 - y0)).copyTo(out(cv::Rect(0, y0, size, y1 - y0)));
    if (progress) progress(b + 1, bands);
  }
  return out;
}

}  // namespace reefgen::infer
