#include "reefgen/terrain/dissection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/terrain/drainage.hpp"
#include "reefgen/terrain/flow.hpp"
#include "reefgen/terrain/realism.hpp"

namespace reefgen::terrain {
namespace {

// Steepest descent on the filled surface and the drainage area of each cell.
struct Drainage {
  cv::Mat1f height_m;
  cv::Mat1b role;
  FlowGraph graph;
  std::vector<float> area_m2;
};

Drainage drain(const cv::Mat1f& height_m, double metres_per_px) {
  Drainage d;
  d.height_m = height_m;
  d.role = sea_and_edge_roles(height_m);
  route_flood(height_m, d.role, metres_per_px, d.graph);
  accumulate_single(d.graph, d.role, float(metres_per_px * metres_per_px), d.area_m2);
  return d;
}

// The field on cells of about kDissectionGridM (averaged down; a coarser
// field is kept as it is). Returns the cell size.
double to_dissection_grid(const cv::Mat1f& h, double metres_per_px, cv::Mat1f& out) {
  if (metres_per_px >= kDissectionGridM) {
    out = h;
    return metres_per_px;
  }
  const double scale = metres_per_px / kDissectionGridM;
  const int cols = std::max(1, int(std::lround(h.cols * scale))), rows = std::max(1, int(std::lround(h.rows * scale)));
  cv::resize(h, out, cv::Size(cols, rows), 0, 0, cv::INTER_AREA);
  return metres_per_px * h.cols / cols;
}

// Fixed-threshold valley channels (kDrainageChannelAreaM2, in a valley at
// kValleySmoothingM), km per km² of land, on the field's own cells.
double valley_density(const cv::Mat1f& h, double metres_per_px, double land_km2) {
  const Drainage d = drain(h, metres_per_px);
  cv::Mat1f smooth, curv, grad;
  const double sigma_px = kValleySmoothingM / metres_per_px;
  cv::GaussianBlur(h, smooth, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  plan_curvature(smooth, metres_per_px, curv, grad);
  double length_m = 0;
  for (const int i : d.graph.stack) {
    const int y = i / h.cols, x = i % h.cols;
    if (h(y, x) <= 0 || d.area_m2[i] < kDrainageChannelAreaM2 || !(curv(y, x) < kValleyCurvature)) continue;
    if (d.graph.inv_length[i] > 0) length_m += 1.0 / d.graph.inv_length[i];
  }
  return length_m * 1e-3 / land_km2;
}

// Each land cell's donor with the largest drainage area (−1 at a divide).
std::vector<int> largest_donors(const Drainage& d) {
  std::vector<int> donor(d.area_m2.size(), -1);
  for (const int i : d.graph.stack) {
    const int r = d.graph.receiver[i];
    if (r == i || d.role(r / d.role.cols, r % d.role.cols) != kActive) continue;
    if (donor[r] < 0 || d.area_m2[i] > d.area_m2[donor[r]]) donor[r] = i;
  }
  return donor;
}

// (log10 A, log10 S) along the main stem of every basin whose head lies in
// the top of the island (kStemHeadShareOfPeak): from each outlet (a land
// cell draining to the sea or the edge) upstream along the largest donor.
void main_stem_pairs(const Drainage& d, std::vector<double>& log10_area, std::vector<double>& log10_slope) {
  const int cols = d.height_m.cols;
  double peak = 0;
  cv::minMaxLoc(d.height_m, nullptr, &peak);
  const std::vector<int> donor = largest_donors(d);
  const cv::Mat1f& z = d.graph.surface;
  for (const int outlet : d.graph.stack) {
    const int r = d.graph.receiver[outlet];
    if (r != outlet && d.role(r / cols, r % cols) == kActive) continue;
    std::vector<int> stem;
    for (int i = outlet; i >= 0; i = donor[i]) stem.push_back(i);
    const int head = stem.back();
    if (d.height_m(head / cols, head % cols) < kStemHeadShareOfPeak * peak) continue;
    for (const int i : stem) {
      const int ri = d.graph.receiver[i];
      if (ri == i) continue;
      const double slope = (z(i / cols, i % cols) - z(ri / cols, ri % cols)) * d.graph.inv_length[i];
      if (!(slope > 0)) continue;  // flats of filled depressions carry no slope
      log10_area.push_back(std::log10(double(d.area_m2[i])));
      log10_slope.push_back(std::log10(slope));
    }
  }
}

}  // namespace

bool slope_area_break(const std::vector<double>& x, const std::vector<double>& y, SlopeAreaBreak& out) {
  if (x.size() != y.size() || x.size() < size_t(2 * kBreakMinPairs)) return false;
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  double best_sse = std::numeric_limits<double>::infinity();
  for (double t = *lo + kBreakMarginDecades; t <= *hi - kBreakMarginDecades; t += kBreakStepDecades) {
    // y = a + b·min(x − t, 0) + c·max(x − t, 0): normal equations of (a, b, c).
    cv::Matx33d xtx = cv::Matx33d::zeros();
    cv::Vec3d xty(0, 0, 0);
    int below = 0;
    for (size_t k = 0; k < x.size(); ++k) {
      const cv::Vec3d row(1, std::min(x[k] - t, 0.0), std::max(x[k] - t, 0.0));
      below += x[k] <= t;
      xtx += row * row.t();
      xty += row * y[k];
    }
    if (below < kBreakMinPairs || int(x.size()) - below < kBreakMinPairs) continue;
    cv::Vec3d p;
    if (!cv::solve(xtx, xty, p, cv::DECOMP_LU)) continue;
    if (!(p[2] < 0) || p[2] > p[1] - kBreakMinExponentDrop) continue;
    double sse = 0;
    for (size_t k = 0; k < x.size(); ++k) {
      const double e = y[k] - (p[0] + p[1] * std::min(x[k] - t, 0.0) + p[2] * std::max(x[k] - t, 0.0));
      sse += e * e;
    }
    if (sse < best_sse) best_sse = sse, out = {t, p[1], p[2]};
  }
  return std::isfinite(best_sse);
}

DissectionStats dissection_stats(const cv::Mat1f& h, double metres_per_px) {
  if (h.empty()) throw Error("dissection: the height field is empty");
  if (!(metres_per_px > 0) || !std::isfinite(metres_per_px))
    throw Error("dissection: metres per pixel must be a positive number");
  if (!cv::checkRange(h)) throw Error("dissection: the height field holds NaN or infinite values");
  const cv::Mat1f hc = h.isContinuous() ? h : h.clone();
  DissectionStats st;
  double peak = 0, sum = 0;
  for (int y = 0; y < hc.rows; ++y)
    for (int x = 0; x < hc.cols; ++x)
      if (hc(y, x) > 0) ++st.land_cells, peak = std::max(peak, double(hc(y, x))), sum += hc(y, x);
  if (st.land_cells == 0) return st;
  st.land_km2 = double(st.land_cells) * metres_per_px * metres_per_px * 1e-6;
  int64_t high = 0;
  for (int y = 0; y < hc.rows; ++y)
    for (int x = 0; x < hc.cols; ++x) high += hc(y, x) > 0.5 * peak;
  st.land_above_half_peak = double(high) / double(st.land_cells);
  st.hypsometric_integral = sum / double(st.land_cells) / peak;
  st.valley_density_per_km = valley_density(hc, metres_per_px, st.land_km2);

  // Channels from the slope–area break, on the dissection grid.
  cv::Mat1f g;
  const double cell_m = to_dissection_grid(hc, metres_per_px, g);
  if (!g.isContinuous()) g = g.clone();
  const Drainage d = drain(g, cell_m);
  std::vector<double> log10_area, log10_slope;
  main_stem_pairs(d, log10_area, log10_slope);
  SlopeAreaBreak brk;
  if (!slope_area_break(log10_area, log10_slope, brk)) return st;
  st.channel_threshold_m2 = std::pow(10.0, brk.log10_area);
  st.channel_exponent = brk.exponent_above;
  double length_m = 0;
  for (const int i : d.graph.stack)
    if (d.area_m2[i] >= st.channel_threshold_m2 && d.graph.inv_length[i] > 0) length_m += 1.0 / d.graph.inv_length[i];
  const double land_km2 = cv::countNonZero(g > 0) * cell_m * cell_m * 1e-6;
  st.drainage_density_per_km = length_m * 1e-3 / land_km2;
  return st;
}

}  // namespace reefgen::terrain
