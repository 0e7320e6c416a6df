#include "reefgen/terrain/realism.hpp"

#include "reefgen/labels.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/terrain/flow.hpp"

namespace reefgen::terrain {

void to_json(nlohmann::json& j, const RealismStats& s) {
  j = {{"land_cells", s.land_cells}, {"flank_cells", s.flank_cells}, {"max_height_m", s.max_height_m},
       {"pits", s.pits},             {"terraces", s.terraces},       {"valleys", s.valleys},
       {"seams_rows", s.seams_rows}, {"seams_cols", s.seams_cols}};
}

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
  const bool has_flank = st.max_height_m >= kFlankMinPeakM;

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
      if (!(has_flank && v > 0 && v >= lo && v <= hi)) continue;
      ++st.flank_cells;
      if (grad_raw(y, x) < flat) ++flats;
      if (grad_s(y, x) > 0.02 && curv(y, x) < -1e-3) ++valleys;
    }
  if (st.flank_cells > 0) {
    st.terraces = double(flats) / double(st.flank_cells);
    st.valleys = double(valleys) / double(st.flank_cells);
  }
  // A canvas of motu and cays (no flank) has no relief a border could step:
  // the medians of centimetre steps along a sand islet's edge scored 8.5 on
  // the border-free atoll. Left at 0, as a field with no qualifying row.
  if (has_flank) {
    st.seams_rows = seam_score(hc, true);
    st.seams_cols = seam_score(hc, false);
  }
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

// max over r of p[r] / (median of p over r ± kSeamWindowRows); rows with p < 0 left out.
double score_of_profile(const std::vector<double>& p) {
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
}  // namespace

double seam_score(const cv::Mat1f& h, bool along_rows) {
  return score_of_profile(step_profile(along_rows ? h : cv::Mat1f(h.t())));
}

namespace {

// Pass 1 of the streamed statistics: what needs the whole field first.
struct FieldTotals {
  int64_t land = 0;
  double max_m = 0;
  std::vector<int> row_pairs, col_pairs;  // land pairs of rows (r, r+1) and of columns (c, c+1)
};

FieldTotals field_totals(const RowSource& read, cv::Size size, int band_rows) {
  FieldTotals t;
  t.row_pairs.assign(size_t(std::max(size.height - 1, 0)), 0);
  t.col_pairs.assign(size_t(std::max(size.width - 1, 0)), 0);
  for (int y0 = 0; y0 < size.height; y0 += band_rows) {
    const int n = std::min(band_rows + 1, size.height - y0);  // one more row for the last pair
    const cv::Mat1f b = read(y0, n);
    if (!cv::checkRange(b)) throw Error("realism: the height field holds NaN or infinite values");
    for (int r = 0; r < std::min(band_rows, n); ++r) {
      const float* a = b.ptr<float>(r);
      const float* next = r + 1 < n ? b.ptr<float>(r + 1) : nullptr;
      for (int c = 0; c < size.width; ++c) {
        if (!(a[c] > 0)) continue;
        ++t.land;
        t.max_m = std::max(t.max_m, double(a[c]));
        if (next && next[c] > 0) ++t.row_pairs[size_t(y0 + r)];
        if (c + 1 < size.width && a[c + 1] > 0) ++t.col_pairs[size_t(c)];
      }
    }
  }
  return t;
}

// Log-spaced histogram bin of a step (m): bin 0 holds steps below 1e-5 m.
constexpr double kStepLogLo = -5, kStepLogHi = 4;
int step_bin(float v) {
  if (!(v >= 1e-5f)) return 0;
  const double t = (std::log10(double(v)) - kStepLogLo) / (kStepLogHi - kStepLogLo);
  return std::clamp(1 + int(t * (kStreamStepBins - 1)), 1, kStreamStepBins - 1);
}
double bin_value(int b) {
  if (b == 0) return 0;
  return std::pow(10.0, kStepLogLo + (b - 0.5) * (kStepLogHi - kStepLogLo) / (kStreamStepBins - 1));
}

}  // namespace

RealismStats realism_stats_streamed(const RowSource& read, cv::Size size, double mpp, const StreamBands& sb) {
  if (size.empty()) throw Error("realism: the height field is empty");
  if (!(mpp > 0) || !std::isfinite(mpp)) throw Error("realism: metres per pixel must be a positive number");
  if (sb.band_rows < 1 || sb.halo_rows < 2) throw Error("realism: bands need ≥ 1 row and a halo of ≥ 2");
  const int H = size.height, W = size.width;
  const FieldTotals t = field_totals(read, size, sb.band_rows);
  RealismStats st;
  st.land_cells = t.land;
  st.max_height_m = t.max_m;
  if (st.land_cells == 0) return st;
  const double sigma_px = 60.0 / mpp;
  // OpenCV's Gaussian kernel for float images reaches 4σ; one more row for the curvature.
  const int halo = std::max(sb.halo_rows, int(std::ceil(4 * sigma_px)) + 3);
  const int busiest_row = t.row_pairs.empty() ? 0 : *std::max_element(t.row_pairs.begin(), t.row_pairs.end());
  const int busiest_col = t.col_pairs.empty() ? 0 : *std::max_element(t.col_pairs.begin(), t.col_pairs.end());
  std::vector<double> row_p(t.row_pairs.size(), -1.0);
  std::vector<uint32_t> col_hist(t.col_pairs.size() * kStreamStepBins, 0);
  const double lo = 0.1 * st.max_height_m, hi = 0.9 * st.max_height_m, flat = std::tan(2.0 * M_PI / 180.0);
  const bool has_flank = st.max_height_m >= kFlankMinPeakM;
  int64_t pits = 0, flats = 0, valleys = 0;
  std::vector<float> steps;
  for (int y0 = 0; y0 < H; y0 += sb.band_rows) {
    const int y1 = std::min(H, y0 + sb.band_rows), r0 = std::max(0, y0 - halo), r1 = std::min(H, y1 + halo);
    const cv::Mat1f b = read(r0, r1 - r0);
    // Pits: the band's cut edges are outlets too (a lower bound past the halo).
    const FloodRoute fr = flood_route(b, sea_and_edge_roles(b));
    cv::Mat1f smooth, curv, grad_s, curv_raw, grad_raw;
    cv::GaussianBlur(b, smooth, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
    plan_curvature(smooth, mpp, curv, grad_s);
    plan_curvature(b, mpp, curv_raw, grad_raw);
    for (int y = y0; y < y1; ++y) {
      const int r = y - r0;
      const float* a = b.ptr<float>(r);
      for (int x = 0; x < W; ++x) {
        const double v = a[x];
        if (v > 0 && fr.filled(r, x) - a[x] > 1.f) ++pits;
        if (x + 1 < W && v > 0 && a[x + 1] > 0 && t.col_pairs[size_t(x)] >= kSeamMinRowShare * busiest_col)
          ++col_hist[size_t(x) * kStreamStepBins + size_t(step_bin(std::abs(a[x + 1] - a[x])))];
        if (!(has_flank && v > 0 && v >= lo && v <= hi)) continue;
        ++st.flank_cells;
        if (grad_raw(r, x) < flat) ++flats;
        if (grad_s(r, x) > 0.02 && curv(r, x) < -1e-3) ++valleys;
      }
      // The row pair (y, y + 1): the next row is in the band's halo or past the field's end.
      if (y + 1 < H && t.row_pairs[size_t(y)] >= kSeamMinRowShare * busiest_row && busiest_row > 0) {
        const float* next = b.ptr<float>(r + 1);
        steps.clear();
        for (int x = 0; x < W; ++x)
          if (a[x] > 0 && next[x] > 0) steps.push_back(std::abs(next[x] - a[x]));
        row_p[size_t(y)] = median_of(steps);
      }
    }
  }
  st.pits = double(pits) / double(st.land_cells);
  if (st.flank_cells > 0) {
    st.terraces = double(flats) / double(st.flank_cells);
    st.valleys = double(valleys) / double(st.flank_cells);
  }
  std::vector<double> col_p(t.col_pairs.size(), -1.0);
  for (size_t c = 0; c < col_p.size(); ++c) {
    if (busiest_col == 0 || t.col_pairs[c] < kSeamMinRowShare * busiest_col) continue;
    // The median's bin: the first whose running count passes half (median_of's element n/2).
    const uint32_t* hist = &col_hist[c * kStreamStepBins];
    int64_t seen = 0;
    const int64_t want = int64_t(t.col_pairs[c]) / 2;
    for (int k = 0; k < kStreamStepBins; ++k)
      if ((seen += hist[k]) > want) {
        col_p[c] = bin_value(k);
        break;
      }
  }
  if (has_flank) {  // as realism_stats: no flank, no seam to judge
    st.seams_rows = score_of_profile(row_p);
    st.seams_cols = score_of_profile(col_p);
  }
  return st;
}

void add_sketch_agreement(SketchAgreement& a, const cv::Mat1f& h, int row0, cv::Size size, const cv::Mat1b& region,
                          const cv::Mat1f& lambda) {
  if (region.empty() || lambda.size() != region.size()) throw Error("sketch agreement: regions and λ differ in size");
  for (int y = 0; y < h.rows; ++y) {
    const int sy = std::min(region.rows - 1, int((row0 + y + 0.5) * region.rows / size.height));
    for (int x = 0; x < h.cols; ++x) {
      const int sx = std::min(region.cols - 1, int((x + 0.5) * region.cols / size.width));
      const int r = region(sy, sx);
      const float v = h(y, x);
      if (r == kIsland || r == kBeach) {
        ++a.land_cells;
        a.land_up += v > 0;
      } else if (r == kAbyss && lambda(sy, sx) < kBrightAbyssMaxLambda) {
        ++a.abyss_cells;
        a.abyss_deep += v < -kAbyssBarDepthM;
      }
    }
  }
  a.land_above_sea = a.land_cells ? double(a.land_up) / double(a.land_cells) : 1.0;
  a.abyss_below_bar = a.abyss_cells ? double(a.abyss_deep) / double(a.abyss_cells) : 1.0;
}

SketchAgreement sketch_agreement(const cv::Mat1f& h, const cv::Mat1b& region, const cv::Mat1f& lambda) {
  SketchAgreement a;
  add_sketch_agreement(a, h, 0, h.size(), region, lambda);
  return a;
}

}  // namespace reefgen::terrain
