#include "reefgen/terrain/ocean_floor.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/ramp.hpp"

namespace reefgen::terrain {

namespace {

// Cells below the knee connected to the border through cells below it
// (4-neighbours), lagoon cells (lagoon ≠ 0) neither counted nor crossed.
cv::Mat1b open_ocean(const cv::Mat1f& h, const cv::Mat1b& lagoon) {
  const int W = h.cols, H = h.rows;
  cv::Mat1b seen(h.size(), uint8_t(0));
  std::vector<cv::Point> stack;
  auto push = [&](int x, int y) {
    if (x < 0 || y < 0 || x >= W || y >= H || seen(y, x) || !(h(y, x) < kFlankKneeM)) return;
    if (!lagoon.empty() && lagoon(y, x)) return;
    seen(y, x) = 1;
    stack.push_back({x, y});
  };
  for (int x = 0; x < W; ++x) push(x, 0), push(x, H - 1);
  for (int y = 0; y < H; ++y) push(0, y), push(W - 1, y);
  while (!stack.empty()) {
    const cv::Point p = stack.back();
    stack.pop_back();
    push(p.x + 1, p.y), push(p.x - 1, p.y), push(p.x, p.y + 1), push(p.x, p.y - 1);
  }
  return seen;
}

// The region's lagoon cells at the heights' size (empty without a region).
cv::Mat1b lagoon_cells(const cv::Mat1b& region, cv::Size size) {
  if (region.empty()) return {};
  cv::Mat1b r = region;
  if (r.size() != size) cv::resize(region, r, size, 0, 0, cv::INTER_NEAREST);
  return r == uint8_t(kLagoon);
}

// How far (σ) OpenCV's float Gaussian kernel reaches.
constexpr double kGaussianReachSigmas = 4;

// The signed distance (cells) from the contour between ocean and the rest,
// half-way between cells: positive on the ocean, negative off it. From a
// cell to its 4-neighbour it changes by at most 1, across the contour too.
cv::Mat1f signed_distance_px(const cv::Mat1b& ocean) {
  cv::Mat1f outside, inside;
  cv::distanceTransform(ocean, outside, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  cv::distanceTransform(ocean == 0, inside, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  // outside is 0 off the ocean and ≥ 1 on it, inside the reverse.
  for (int y = 0; y < ocean.rows; ++y) {
    float* o = outside.ptr<float>(y);
    const float* i = inside.ptr<float>(y);
    for (int x = 0; x < ocean.cols; ++x) o[x] = o[x] > 0 ? o[x] - 0.5f : 0.5f - i[x];
  }
  return outside;
}

// f with a frame `pad` cells wide that continues it oddly about its edge
// cells (f(−k) = 2 f(0) − f(k)): a ramp that meets the canvas edge goes on
// as a ramp (a mirror would fold it, and a blur flatten the flank there).
cv::Mat1f continued_oddly(const cv::Mat1f& f, int pad) {
  const int W = f.cols, H = f.rows;
  cv::Mat1f p(H + 2 * pad, W + 2 * pad);
  f.copyTo(p(cv::Rect(pad, pad, W, H)));
  for (int y = pad; y < pad + H; ++y) {
    float* d = p.ptr<float>(y);
    for (int k = 1; k <= pad; ++k) {
      d[pad - k] = 2 * d[pad] - d[pad + std::min(k, W - 1)];
      d[pad + W - 1 + k] = 2 * d[pad + W - 1] - d[pad + W - 1 - std::min(k, W - 1)];
    }
  }
  for (int k = 1; k <= pad; ++k) {
    const float *top = p.ptr<float>(pad), *top_in = p.ptr<float>(pad + std::min(k, H - 1));
    const float *bot = p.ptr<float>(pad + H - 1), *bot_in = p.ptr<float>(pad + H - 1 - std::min(k, H - 1));
    float *above = p.ptr<float>(pad - k), *below = p.ptr<float>(pad + H - 1 + k);
    for (int x = 0; x < p.cols; ++x) above[x] = 2 * top[x] - top_in[x], below[x] = 2 * bot[x] - bot_in[x];
  }
  return p;
}

// f blurred by sigma_px, continued oddly beyond its edges.
cv::Mat1f blur_continued(const cv::Mat1f& f, double sigma_px) {
  const int pad = int(std::ceil(kGaussianReachSigmas * sigma_px));
  cv::Mat1f p = continued_oddly(f, pad);
  cv::GaussianBlur(p, p, cv::Size(), sigma_px, 0, cv::BORDER_REFLECT);
  return p(cv::Rect(pad, pad, f.cols, f.rows)).clone();
}

// Catmull–Rom weights of the four cells round a position t ∈ [0, 1) past
// the second: a cubic whose slope is continuous from cell to cell (a
// bilinear read back creases at every coarse cell line, a grid in a
// hill-shade) and that reproduces a ramp exactly.
std::array<float, 4> catmull_rom(float t) {
  const float t2 = t * t, t3 = t2 * t;
  return {0.5f * (-t3 + 2 * t2 - t), 0.5f * (3 * t3 - 5 * t2 + 2), 0.5f * (-3 * t3 + 4 * t2 + t), 0.5f * (t3 - t2)};
}

// A coarse field read back at `size` by Catmull–Rom (cell centres as
// cv::resize aligns them), continued oddly past its edge cells, so that a
// ramp is read back as the same ramp up to the canvas edge.
cv::Mat1f read_back(const cv::Mat1f& coarse, cv::Size size) {
  constexpr int kPad = 2;
  const cv::Mat1f p = continued_oddly(coarse, kPad);
  const double sx = double(coarse.cols) / size.width, sy = double(coarse.rows) / size.height;
  std::vector<int> col(size_t(size.width));
  std::vector<std::array<float, 4>> wx(size_t(size.width));
  for (int x = 0; x < size.width; ++x) {
    const double u = (x + 0.5) * sx - 0.5 + kPad;
    col[size_t(x)] = std::min(int(u), p.cols - 3);
    wx[size_t(x)] = catmull_rom(float(u - col[size_t(x)]));
  }
  cv::Mat1f out(size);
  for (int y = 0; y < size.height; ++y) {
    const double v = (y + 0.5) * sy - 0.5 + kPad;
    const int j = std::min(int(v), p.rows - 3);
    const std::array<float, 4> wy = catmull_rom(float(v - j));
    float* o = out.ptr<float>(y);
    for (int x = 0; x < size.width; ++x) {
      const int i = col[size_t(x)];
      float sum = 0;
      for (int b = 0; b < 4; ++b) {
        const float* r = p.ptr<float>(j - 1 + b) + i - 1;
        sum += wy[size_t(b)] * (wx[size_t(x)][0] * r[0] + wx[size_t(x)][1] * r[1] + wx[size_t(x)][2] * r[2] + wx[size_t(x)][3] * r[3]);
      }
      o[x] = sum;
    }
  }
  return out;
}

// The distance (cells) from each ocean cell to the nearest cell that is not
// ocean: the reef's foot, the land, a lagoon (0 off the ocean). A canvas
// that is all ocean has no reef to be near: every cell is far from one.
// The exact distance to a pixelated, wavy contour is a cone of facets whose
// creases a hill-shade draws as fans of straight lines (looked at): so it is
// the signed distance blurred, by kFlankDistanceBlurPx near the reef and by
// kFlankFarBlurShare of the canvas side (at least 4× that) from 3 near blurs
// out to 3 far ones, blended by a smoothstep. A Gaussian leaves a straight
// contour's ramp as it is, so the first ocean cells still sink by about half
// a cell's slope, and a lone ocean cell among reef cells is not pushed down
// a needle. The far blur runs on a grid coarser by its ratio to the near one
// (area-averaged down, read back by Catmull–Rom: the blurred field is
// smooth over σ). Each blur lies within σ √(π/2) of the exact signed distance.
cv::Mat1f smooth_distance_px(const cv::Mat1b& ocean) {
  if (cv::countNonZero(ocean) == int(ocean.total()))
    return cv::Mat1f(ocean.size(), std::numeric_limits<float>::infinity());
  const cv::Mat1f exact = signed_distance_px(ocean);
  cv::Mat1f near = blur_continued(exact, kFlankDistanceBlurPx);
  const int side = std::max(ocean.cols, ocean.rows);
  const int factor = std::max(kFlankFarBlurMinRatio, int(std::lround(kFlankFarBlurShare * side / kFlankDistanceBlurPx)));
  const cv::Size coarse_size((ocean.cols + factor - 1) / factor, (ocean.rows + factor - 1) / factor);
  if (std::min(coarse_size.width, coarse_size.height) >= 2) {
    cv::Mat1f coarse;
    cv::resize(exact, coarse, coarse_size, 0, 0, cv::INTER_AREA);
    const cv::Mat1f far = read_back(blur_continued(coarse, kFlankDistanceBlurPx), ocean.size());
    const double from = 3 * kFlankDistanceBlurPx, to = 3 * kFlankDistanceBlurPx * factor;
    for (int y = 0; y < near.rows; ++y) {
      float* n = near.ptr<float>(y);
      const float* f = far.ptr<float>(y);
      for (int x = 0; x < near.cols; ++x) {
        const double t = std::clamp((n[x] - from) / (to - from), 0.0, 1.0), w = smoothstep(t);
        n[x] = float(n[x] + w * (f[x] - n[x]));
      }
    }
  }
  return cv::max(near, 0.f);
}

void check_floor(double ocean_floor_m, double cell_m) {
  if (!std::isfinite(ocean_floor_m) || ocean_floor_m < kDeepestOceanFloorM || ocean_floor_m > kShallowestOceanFloorM)
    throw Error("ocean floor " + std::to_string(ocean_floor_m) + " m is out of range; expected [-11000, -60] m (above -60 m there is no flank to continue)");
  if (!std::isfinite(cell_m) || cell_m <= 0)
    throw Error("ocean floor: the cell size " + std::to_string(cell_m) + " m is not a positive number");
}

}  // namespace

double flank_drop_m(double distance_m, double span_m) {
  if (span_m <= 0) return 0;
  return span_m * std::tanh(distance_m * kFlankTopSlope / span_m);
}

void deepen_flank(cv::Mat1f& h, double ocean_floor_m, double cell_m, const cv::Mat1b& region) {
  check_floor(ocean_floor_m, cell_m);
  if (h.empty()) return;
  const cv::Mat1b ocean = open_ocean(h, lagoon_cells(region, h.size()));
  if (cv::countNonZero(ocean) == 0) return;
  double lowest = 0;
  cv::minMaxLoc(h, &lowest, nullptr, nullptr, nullptr, ocean);
  if (ocean_floor_m >= lowest) return;
  const double span_m = lowest - ocean_floor_m;
  const cv::Mat1f distance_px = smooth_distance_px(ocean);
  const float floor_m = float(ocean_floor_m);
  for (int y = 0; y < h.rows; ++y) {
    float* r = h.ptr<float>(y);
    const uint8_t* o = ocean.ptr<uint8_t>(y);
    const float* d = distance_px.ptr<float>(y);
    for (int x = 0; x < h.cols; ++x)
      if (o[x]) r[x] = std::max(floor_m, float(r[x] - flank_drop_m(double(d[x]) * cell_m, span_m)));
  }
}

}  // namespace reefgen::terrain
