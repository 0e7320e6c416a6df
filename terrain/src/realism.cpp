#include "reefgen/terrain/realism.hpp"

#include "reefgen/labels.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/terrain/flow.hpp"

namespace reefgen::terrain {

void plan_curvature(const cv::Mat1f& s, double metres_per_px, cv::Mat1f& curvature, cv::Mat1f& gradient) {
  const int H = s.rows, W = s.cols;
  curvature.create(H, W);
  gradient.create(H, W);
  const double d = metres_per_px;
  for (int y = 0; y < H; ++y) {
    const int ym = std::max(y - 1, 0), yp = std::min(y + 1, H - 1);
    for (int x = 0; x < W; ++x) {
      const int xm = std::max(x - 1, 0), xp = std::min(x + 1, W - 1);
      // Image rows grow downwards; the curvature's sign does not depend on
      // the y orientation (h_y appears squared or with h_xy, which flips too).
      const double hx = (s(y, xp) - s(y, xm)) / ((xp - xm) * d);
      const double hy = (s(yp, x) - s(ym, x)) / ((yp - ym) * d);
      const double hxx = (s(y, xp) - 2.0 * s(y, x) + s(y, xm)) / (d * d);
      const double hyy = (s(yp, x) - 2.0 * s(y, x) + s(ym, x)) / (d * d);
      const double hxy = (s(yp, xp) - s(yp, xm) - s(ym, xp) + s(ym, xm)) / (4.0 * d * d);
      const double g2 = hx * hx + hy * hy;
      gradient(y, x) = static_cast<float>(std::sqrt(g2));
      curvature(y, x) = g2 > 0 ? static_cast<float>(-(hxx * hy * hy - 2.0 * hxy * hx * hy + hyy * hx * hx) /
                                                    std::pow(g2, 1.5))
                               : 0.f;
    }
  }
}

RealismStats realism_stats(const cv::Mat1f& h, double metres_per_px) {
  if (h.empty()) throw Error("realism: the height field is empty");
  if (!(metres_per_px > 0) || !std::isfinite(metres_per_px))
    throw Error("realism: metres per pixel must be a positive number");
  if (!cv::checkRange(h)) throw Error("realism: the height field holds NaN or infinite values");
  const cv::Mat1f hc = h.isContinuous() ? h : h.clone();
  const int H = hc.rows, W = hc.cols;
  RealismStats st;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (hc(y, x) > 0) {
        ++st.land_cells;
        st.max_height_m = std::max(st.max_height_m, double(hc(y, x)));
      }
  if (st.land_cells == 0) return st;

  // Pits: filled from the sea and the canvas edge.
  const FloodRoute fr = flood_route(hc, sea_and_edge_roles(hc));
  int64_t pits = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (hc(y, x) > 0 && fr.filled(y, x) - hc(y, x) > 1.f) ++pits;
  st.pits = double(pits) / double(st.land_cells);

  // Flank, slope on the raw heights; curvature on the σ = 60 m smoothed heights.
  const double lo = 0.1 * st.max_height_m, hi = 0.9 * st.max_height_m;
  const double sigma_px = 60.0 / metres_per_px;
  cv::Mat1f smooth;
  cv::GaussianBlur(hc, smooth, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  cv::Mat1f curv, grad_s, curv_raw, grad_raw;
  plan_curvature(smooth, metres_per_px, curv, grad_s);
  plan_curvature(hc, metres_per_px, curv_raw, grad_raw);
  const double flat = std::tan(2.0 * M_PI / 180.0);
  int64_t flats = 0, valleys = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double v = hc(y, x);
      if (!(v > 0 && v >= lo && v <= hi)) continue;
      ++st.flank_cells;
      if (grad_raw(y, x) < flat) ++flats;
      if (grad_s(y, x) > 0.02 && curv(y, x) < -1e-3) ++valleys;
    }
  if (st.flank_cells > 0) {
    st.terraces = double(flats) / double(st.flank_cells);
    st.valleys = double(valleys) / double(st.flank_cells);
  }
  st.seams_rows = seam_score(hc, true);
  st.seams_cols = seam_score(hc, false);
  return st;
}

namespace {
double median_of(std::vector<float>& v) {
  const auto mid = v.begin() + long(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// p[r] of seam_score for the rows of h (columns: pass the transpose); -1 for
// a row left out.
std::vector<double> step_profile(const cv::Mat1f& h) {
  const int H = h.rows, W = h.cols;
  std::vector<int> land(size_t(std::max(H - 1, 0)), 0);
  int busiest = 0;
  for (int r = 0; r + 1 < H; ++r) {
    const float* a = h.ptr<float>(r);
    const float* b = h.ptr<float>(r + 1);
    for (int c = 0; c < W; ++c) land[size_t(r)] += a[c] > 0 && b[c] > 0;
    busiest = std::max(busiest, land[size_t(r)]);
  }
  std::vector<double> p(land.size(), -1.0);
  std::vector<float> steps;
  for (int r = 0; r + 1 < H; ++r) {
    if (busiest == 0 || land[size_t(r)] < kSeamMinRowShare * busiest) continue;
    const float* a = h.ptr<float>(r);
    const float* b = h.ptr<float>(r + 1);
    steps.clear();
    for (int c = 0; c < W; ++c)
      if (a[c] > 0 && b[c] > 0) steps.push_back(std::abs(b[c] - a[c]));
    p[size_t(r)] = median_of(steps);
  }
  return p;
}
}  // namespace

double seam_score(const cv::Mat1f& h, bool along_rows) {
  const std::vector<double> p = step_profile(along_rows ? h : cv::Mat1f(h.t()));
  double score = 0;
  std::vector<float> near;
  for (size_t r = 0; r < p.size(); ++r) {
    if (p[r] < 0) continue;
    near.clear();
    const size_t lo = r >= size_t(kSeamWindowRows) ? r - kSeamWindowRows : 0;
    const size_t hi = std::min(p.size() - 1, r + kSeamWindowRows);
    for (size_t k = lo; k <= hi; ++k)
      if (p[k] >= 0) near.push_back(float(p[k]));
    const double ref = median_of(near);
    // A flat run (ref 0) has no step to compare with: a seam there would have
    // raised its own neighbours' median, so it is left out rather than infinite.
    if (ref > 0) score = std::max(score, p[r] / ref);
  }
  return score;
}

SketchAgreement sketch_agreement(const cv::Mat1f& h, const cv::Mat1b& region, const cv::Mat1f& lambda) {
  if (region.empty() || lambda.size() != region.size()) throw Error("sketch agreement: regions and λ differ in size");
  SketchAgreement a;
  int64_t land_up = 0, abyss_deep = 0;
  for (int y = 0; y < h.rows; ++y) {
    const int sy = std::min(region.rows - 1, int((y + 0.5) * region.rows / h.rows));
    for (int x = 0; x < h.cols; ++x) {
      const int sx = std::min(region.cols - 1, int((x + 0.5) * region.cols / h.cols));
      const int r = region(sy, sx);
      const float v = h(y, x);
      if (r == kIsland || r == kBeach) {
        ++a.land_cells;
        land_up += v > 0;
      } else if (r == kAbyss && lambda(sy, sx) < kBrightAbyssMaxLambda) {
        ++a.abyss_cells;
        abyss_deep += v < -kAbyssBarDepthM;
      }
    }
  }
  a.land_above_sea = a.land_cells ? double(land_up) / double(a.land_cells) : 1.0;
  a.abyss_below_bar = a.abyss_cells ? double(abyss_deep) / double(a.abyss_cells) : 1.0;
  return a;
}

}  // namespace reefgen::terrain
