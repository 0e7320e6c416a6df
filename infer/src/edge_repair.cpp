#include "reefgen/infer/edge_repair.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/ramp.hpp"

#include "masked_blur.hpp"

namespace reefgen::infer {

namespace {

// Along-edge smoothing of the repaired lines' weight, model cells: an island
// at the edge fades the repair out over a few cells, not in one step.
constexpr double kAlongEdgeSigmaPx = 3;

// The top edge of h (rows 0..2B−1 across it; the other edges are this one on
// a flipped or transposed copy).
void repair_top_edge(cv::Mat1f& h, const EdgeRepairParams& p) {
  const int B = p.band_px, W = h.cols;
  // 1 where the whole line (band and fit window) is open sea.
  cv::Mat1f open(1, W, 0.f);
  for (int x = 0; x < W; ++x) {
    bool sea = true;
    for (int d = 0; d < 2 * B && sea; ++d) sea = h(d, x) < p.open_sea_m;
    open(0, x) = sea ? 1.f : 0.f;
  }
  // Shrunk by 2σ before the blur, so the weight has eased to ~0 before a
  // line that may not move: no step along the edge beside an island.
  const int shrink = int(std::ceil(2 * kAlongEdgeSigmaPx));
  cv::Mat1f inner;
  cv::erode(open, inner, cv::Mat1b::ones(1, 2 * shrink + 1), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(1));
  cv::Mat1f weight;
  cv::GaussianBlur(inner, weight, cv::Size(0, 0), kAlongEdgeSigmaPx, 0, cv::BORDER_REPLICATE);
  for (int x = 0; x < W; ++x) weight(0, x) = std::min(weight(0, x), open(0, x));  // a line with land is never moved
  // The fit window d ∈ [B, 2B): centred abscissa u = d − c.
  const double c = B + (B - 1) / 2.0;
  double suu = 0;
  for (int d = B; d < 2 * B; ++d) suu += (d - c) * (d - c);
  for (int x = 0; x < W; ++x) {
    if (weight(0, x) <= 0) continue;
    double mean = 0, suh = 0;
    for (int d = B; d < 2 * B; ++d) mean += h(d, x);
    mean /= B;
    for (int d = B; d < 2 * B; ++d) suh += (d - c) * (h(d, x) - mean);
    const double slope = suu > 0 ? suh / suu : 0;
    for (int d = 0; d < B; ++d) {
      // 1 over the band's outer half, easing to 0 at B
      const double t = std::clamp(2.0 * (B - d) / B, 0.0, 1.0), s = smoothstep(t);
      const double trend = mean + slope * (d - c);
      h(d, x) = float(h(d, x) + weight(0, x) * s * (trend - h(d, x)));
    }
  }
}

// The lines' ends at the band's inner edge meet in each corner square, and
// the two passes' fits disagree there by a few centimetres — enough to draw
// the square in a hill-shade. A light smoothing (σ kBandSmoothSigmaPx) of
// the open sea over the band and a little past it blends them.
constexpr double kBandSmoothSigmaPx = 2;
void smooth_band(cv::Mat1f& h, const EdgeRepairParams& p) {
  const int B = p.band_px, reach = B + int(std::ceil(2 * kBandSmoothSigmaPx));
  cv::Mat1f smooth, highest;
  cv::GaussianBlur(h, smooth, cv::Size(0, 0), kBandSmoothSigmaPx, kBandSmoothSigmaPx, cv::BORDER_REPLICATE);
  // Only where the whole kernel (±2σ) is open sea: a cell beside land or
  // reef is never pulled towards it.
  const int k = 2 * int(std::ceil(2 * kBandSmoothSigmaPx)) + 1;
  cv::dilate(h, highest, cv::Mat1b::ones(k, k), cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  // ... and eased in over another kernel's width, so it does not switch on
  // from one cell to the next beside an island.
  cv::Mat1f allowed(h.size());
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) allowed(y, x) = highest(y, x) < p.open_sea_m ? 1.f : 0.f;
  cv::erode(allowed, allowed, cv::Mat1b::ones(k, k), cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  cv::GaussianBlur(allowed, allowed, cv::Size(0, 0), kBandSmoothSigmaPx, kBandSmoothSigmaPx, cv::BORDER_REPLICATE);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      const int d = std::min(std::min(x, h.cols - 1 - x), std::min(y, h.rows - 1 - y));
      if (d >= reach || !(highest(y, x) < p.open_sea_m)) continue;
      const double t = std::clamp(double(reach - d) / (reach - B / 2.0), 0.0, 1.0);
      const double w = smoothstep(t) * allowed(y, x);
      h(y, x) = float(h(y, x) + w * (smooth(y, x) - h(y, x)));
    }
}

}  // namespace

void repair_canvas_edges(cv::Mat1f& h, const EdgeRepairParams& p) {
  if (p.band_px <= 0 || h.rows < 2 * p.band_px || h.cols < 2 * p.band_px) return;
  // top, bottom (flipped), left and right (transposed, then flipped)
  repair_top_edge(h, p);
  cv::Mat1f f;
  cv::flip(h, f, 0);
  repair_top_edge(f, p);
  cv::flip(f, h, 0);
  cv::Mat1f t = h.t();
  repair_top_edge(t, p);
  cv::flip(t, f, 0);
  repair_top_edge(f, p);
  cv::flip(f, t, 0);
  cv::Mat1f(t.t()).copyTo(h);
  smooth_band(h, p);
}


namespace {
// The floor at the fore reef's foot blurred over the floor alone, where the
// open sea's smoothing did not reach (its weight `done` below 1; see
// smooth_open_sea).
void smooth_fore_reef_foot(cv::Mat1f& h, const cv::Mat1f& done, const OpenSeaSmoothing& p) {
  const cv::Mat1b floor = h < float(p.foot_from_m);
  if (cv::countNonZero(floor) == 0) return;
  const MaskedBlur deep = masked_blur(h, floor, p.sigma_px);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      if (!floor(y, x) || deep.weight(y, x) < 1e-6f || done(y, x) >= 1.f) continue;
      const double t = std::clamp((p.foot_from_m - h(y, x)) / (p.foot_from_m - p.foot_full_m), 0.0, 1.0);
      const double w = smoothstep(t) * (1.0 - done(y, x));
      const float mean = std::min(deep.sum(y, x) / deep.weight(y, x), float(p.foot_from_m));
      h(y, x) = float(h(y, x) + w * (mean - h(y, x)));
    }
}
}  // namespace

void smooth_open_sea(cv::Mat1f& h, const OpenSeaSmoothing& p) {
  if (p.sigma_px <= 0) return;
  cv::Mat1f smooth, highest, done(h.size());
  cv::GaussianBlur(h, smooth, cv::Size(0, 0), p.sigma_px, p.sigma_px, cv::BORDER_REPLICATE);
  const int k = 2 * int(std::ceil(2 * p.sigma_px)) + 1;
  cv::dilate(h, highest, cv::Mat1b::ones(k, k), cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      const double t = std::clamp((p.from_m - highest(y, x)) / (p.from_m - p.full_m), 0.0, 1.0);
      const double w = smoothstep(t);
      h(y, x) = float(h(y, x) + w * (smooth(y, x) - h(y, x)));
      done(y, x) = float(w);
    }
  smooth_fore_reef_foot(h, done, p);
}

void smooth_lagoon_floor(cv::Mat1f& h, const cv::Mat1b& label, const LagoonSmoothing& p) {
  if (p.sigma_px <= 0) return;
  if (label.size() != h.size()) throw Error("internal: the lagoon's labels and heights differ in size");
  const cv::Mat1b inside = ((label == kLagoon) | (label == kReef)) & (h < 0.f);
  if (cv::countNonZero(inside) == 0) return;
  const MaskedBlur water = masked_blur(h, inside, p.sigma_px);
  const cv::Mat1f &sum = water.sum, &weight = water.weight;
  cv::Mat1f from_edge;
  cv::distanceTransform(inside, from_edge, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      if (!inside(y, x) || weight(y, x) < 1e-6f) continue;
      const double t = std::clamp((from_edge(y, x) - 1.0) / (2 * p.sigma_px), 0.0, 1.0);
      const double w = smoothstep(t);
      // Never above the sea: a mean of water is water, kept so in float.
      const float mean = std::min(sum(y, x) / weight(y, x), -1e-3f);
      h(y, x) = float(h(y, x) + w * (mean - h(y, x)));
    }
}

}  // namespace reefgen::infer
