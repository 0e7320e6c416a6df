#include "reefgen/terrain/landform.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/terrain/drainage.hpp"
#include "reefgen/terrain/flow.hpp"

namespace reefgen::terrain {
namespace {


double coefficient_of_variation(const std::vector<double>& v) {
  if (v.size() < 2) return 0;
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
  double ss = 0;
  for (const double x : v) ss += (x - mean) * (x - mean);
  return mean > 0 ? std::sqrt(ss / double(v.size())) / mean : 0;
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// The field on the landform grid (kLandformCells across the island).
struct Grid {
  cv::Mat1f h;
  double cell_m = 0;
  double diameter_cells = 0;
  double peak_m = 0;
};

Grid landform_grid(const cv::Mat1f& height_m, double metres_per_px) {
  const int land = cv::countNonZero(height_m > 0);
  if (land < 100) throw Error("landform: fewer than 100 land cells: no island to read");
  const double diameter_m = 2 * std::sqrt(land * metres_per_px * metres_per_px / CV_PI);
  Grid g;
  const double target_m = diameter_m / kLandformCells;
  if (target_m <= metres_per_px) {
    g.h = height_m;
    g.cell_m = metres_per_px;
  } else {
    const double s = metres_per_px / target_m;
    const int cols = std::max(8, int(std::lround(height_m.cols * s))), rows = std::max(8, int(std::lround(height_m.rows * s)));
    cv::resize(height_m, g.h, cv::Size(cols, rows), 0, 0, cv::INTER_AREA);
    g.cell_m = metres_per_px * height_m.cols / cols;
  }
  g.diameter_cells = diameter_m / g.cell_m;
  double lo, hi;
  cv::minMaxLoc(g.h, &lo, &hi);
  g.peak_m = hi;
  return g;
}

// Bilinear sample, the sea beyond the field.
float sample(const cv::Mat1f& m, double x, double y) {
  if (x < 0 || y < 0 || x > m.cols - 1 || y > m.rows - 1) return -1.f;
  const int x0 = std::min(int(x), m.cols - 2), y0 = std::min(int(y), m.rows - 2);
  const float fx = float(x - x0), fy = float(y - y0);
  return (1 - fy) * ((1 - fx) * m(y0, x0) + fx * m(y0, x0 + 1)) + fy * ((1 - fx) * m(y0 + 1, x0) + fx * m(y0 + 1, x0 + 1));
}

// The summit (highest point of `smooth`, the heights blurred at the detrend scale)
// and the distance to the first sea cell along each of n rays from it.
struct Rays {
  cv::Point2d summit;
  std::vector<double> coast_cells;
};

Rays coast_rays(const Grid& g, const cv::Mat1f& smooth, int n) {
  cv::Point at;
  cv::minMaxLoc(smooth, nullptr, nullptr, nullptr, &at);
  Rays r{cv::Point2d(at.x, at.y), std::vector<double>(size_t(n), 0.0)};
  const double far = std::hypot(g.h.cols, g.h.rows);
  for (int k = 0; k < n; ++k) {
    const double a = 2 * CV_PI * k / n, c = std::cos(a), s = std::sin(a);
    double d = 0;
    while (d < far && sample(g.h, r.summit.x + d * c, r.summit.y + d * s) > 0) d += 0.5;
    r.coast_cells[size_t(k)] = d;
  }
  return r;
}

// Indices of the minima of a circular profile at least `prominence` below
// the lower of the highest values within `window` samples either side.
std::vector<int> valley_minima(const std::vector<double>& v, int window, double prominence) {
  const int n = int(v.size());
  std::vector<int> out;
  for (int i = 0; i < n; ++i) {
    double left = v[size_t(i)], right = v[size_t(i)];
    bool lowest = true;
    for (int k = 1; k <= window && lowest; ++k) {
      const double a = v[size_t((i - k + n) % n)], b = v[size_t((i + k) % n)];
      // Ties break towards the first index, so a flat floor counts once.
      if (a < v[size_t(i)] || b < v[size_t(i)] || (a == v[size_t(i)])) lowest = false;
      left = std::max(left, a), right = std::max(right, b);
    }
    if (lowest && std::min(left, right) - v[size_t(i)] >= prominence) out.push_back(i);
  }
  return out;
}

// Power of a real circular profile at integer wavenumbers first..last (DFT).
std::vector<double> angular_power(const std::vector<double>& v, int first, int last) {
  const int n = int(v.size());
  std::vector<double> p;
  for (int k = first; k <= last && k < n / 2; ++k) {
    double re = 0, im = 0;
    for (int i = 0; i < n; ++i) {
      const double a = 2 * CV_PI * k * i / n;
      re += v[size_t(i)] * std::cos(a), im -= v[size_t(i)] * std::sin(a);
    }
    p.push_back(re * re + im * im);
  }
  return p;
}

// A profile's spectrum against its smooth fit (log P = a + b·log k, least
// squares over the band: terrain's red spectrum): the largest of P / fit over
// the median of P / fit. A comb of equal valleys stands as one peak.
double spectrum_peak_over_fit(const std::vector<double>& power, int first_k) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int n = 0;
  for (size_t i = 0; i < power.size(); ++i) {
    if (!(power[i] > 0)) continue;
    const double x = std::log(double(first_k) + double(i)), y = std::log(power[i]);
    sx += x, sy += y, sxx += x * x, sxy += x * y, ++n;
  }
  const double den = n * sxx - sx * sx;
  if (n < 8 || !(den > 0)) return 0;
  const double b = (n * sxy - sx * sy) / den, a = (sy - b * sx) / n;
  std::vector<double> ratio;
  for (size_t i = 0; i < power.size(); ++i)
    if (power[i] > 0) ratio.push_back(power[i] / std::exp(a + b * std::log(double(first_k) + double(i))));
  const double med = median_of(ratio);
  return med > 0 ? *std::max_element(ratio.begin(), ratio.end()) / med : 0;
}

// Spacing CV, spectrum peak ratio and valley count on the three circles.
void circle_figures(const Grid& g, const Rays& rays, const cv::Mat1f& detrended, LandformStats& s) {
  const int n_rays = int(rays.coast_cells.size());
  const int window = std::max(2, int(std::lround(kValleyWindowShareOfDiameter * g.diameter_cells)));
  double cv_sum = 0, ratio_sum = 0;
  int cv_n = 0, ratio_n = 0;
  for (const double share : kCircleShares) {
    const double mean_r = share * std::accumulate(rays.coast_cells.begin(), rays.coast_cells.end(), 0.0) / n_rays;
    // About one sample per cell along the circle, and at least 360.
    const int n = std::max(360, int(std::ceil(2 * CV_PI * mean_r)));
    std::vector<double> prof(static_cast<size_t>(n)), raw(static_cast<size_t>(n)), arc(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) {
      const double a = 2 * CV_PI * i / n;
      const double rr = share * rays.coast_cells[size_t(std::lround(double(i) * n_rays / n)) % size_t(n_rays)];
      const double x = rays.summit.x + rr * std::cos(a), y = rays.summit.y + rr * std::sin(a);
      prof[size_t(i)] = sample(detrended, x, y);
      raw[size_t(i)] = sample(g.h, x, y);
      arc[size_t(i)] = rr * 2 * CV_PI / n;
    }
    const auto minima = valley_minima(prof, window, kValleyProminenceShareOfPeak * g.peak_m);
    s.valleys_on_circles += int(minima.size());
    if (minima.size() >= 4) {
      std::vector<double> gaps;
      for (size_t k = 0; k < minima.size(); ++k) {
        const int a = minima[k], b = minima[(k + 1) % minima.size()];
        double len = 0;
        for (int i = a; i != b; i = (i + 1) % n) len += arc[size_t(i)];
        gaps.push_back(len);
      }
      cv_sum += coefficient_of_variation(gaps), ++cv_n;
    }
    const double r = spectrum_peak_over_fit(angular_power(raw, kSpectrumFirst, kSpectrumLast), kSpectrumFirst);
    if (r > 0) ratio_sum += r, ++ratio_n;
  }
  s.spacing_cv = cv_n ? cv_sum / cv_n : 0;
  s.spectrum_peak_ratio = ratio_n ? ratio_sum / ratio_n : 0;
}

// RMS detrended relief per sector round the summit, between 20 % and 90 %
// of the way to the coast (the summit's and the shore's own forms apart).
double sector_dissection_cv(const Grid& g, const Rays& rays, const cv::Mat1f& detrended) {
  const int n_rays = int(rays.coast_cells.size());
  std::vector<double> ss(kSectors, 0.0), count(kSectors, 0.0);
  for (int y = 0; y < g.h.rows; ++y)
    for (int x = 0; x < g.h.cols; ++x) {
      if (g.h(y, x) <= 0) continue;
      const double dx = x - rays.summit.x, dy = y - rays.summit.y;
      double a = std::atan2(dy, dx);
      if (a < 0) a += 2 * CV_PI;
      const double coast = rays.coast_cells[size_t(std::lround(a / (2 * CV_PI) * n_rays)) % size_t(n_rays)];
      const double t = std::hypot(dx, dy) / std::max(coast, 1.0);
      if (t < 0.2 || t > 0.9) continue;
      const int k = std::min(kSectors - 1, int(a / (2 * CV_PI) * kSectors));
      ss[size_t(k)] += double(detrended(y, x)) * detrended(y, x), count[size_t(k)] += 1;
    }
  std::vector<double> rms;
  for (int k = 0; k < kSectors; ++k)
    if (count[size_t(k)] > 0) rms.push_back(std::sqrt(ss[size_t(k)] / count[size_t(k)]));
  return coefficient_of_variation(rms);
}

// Hack's exponent and valleys per coastal basin, on the steepest-descent
// drainage of the Priority-Flood filled surface.
void drainage_figures(const Grid& g, LandformStats& s) {
  cv::Mat1f h = g.h.isContinuous() ? g.h : g.h.clone();
  const cv::Mat1b role = sea_and_edge_roles(h);
  FlowGraph graph;
  route_flood(h, role, g.cell_m, graph);
  std::vector<float> area;
  const float cell_area = float(g.cell_m * g.cell_m);
  accumulate_single(graph, role, cell_area, area);
  // Upstream length along the longest path: donors before receivers.
  std::vector<double> length(area.size(), 0.0);
  std::vector<int> big_donors(area.size(), 0);
  const double land_m2 = double(cv::countNonZero(h > 0)) * cell_area;
  const float valley_m2 = float(kValleyAreaShare * land_m2);
  for (auto it = graph.stack.rbegin(); it != graph.stack.rend(); ++it) {
    const int i = *it, r = graph.receiver[size_t(i)];
    if (r == i || graph.inv_length[size_t(i)] <= 0) continue;
    length[size_t(r)] = std::max(length[size_t(r)], length[size_t(i)] + 1.0 / graph.inv_length[size_t(i)]);
    if (area[size_t(i)] >= valley_m2) ++big_donors[size_t(r)];
  }
  // Hack: least squares of log L on log A over channel cells (≥ 10 cells).
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int n = 0, heads = 0, outlets = 0;
  for (const int i : graph.stack) {
    const int r = graph.receiver[size_t(i)];
    if (area[size_t(i)] >= 10 * cell_area && length[size_t(i)] > 0) {
      const double x = std::log10(area[size_t(i)]), y = std::log10(length[size_t(i)]);
      sx += x, sy += y, sxx += x * x, sxy += x * y, ++n;
    }
    if (area[size_t(i)] < valley_m2) continue;
    if (big_donors[size_t(i)] == 0) ++heads;
    const bool to_sea = r == i || role(r / h.cols, r % h.cols) != kActive;
    if (to_sea) ++outlets;
  }
  const double den = n * sxx - sx * sx;
  s.hack_exponent = n > 2 && den > 0 ? (n * sxy - sx * sy) / den : 0;
  s.valleys_per_basin = outlets ? double(heads) / outlets : 0;
}

// The valley depth on the grid (closing less heights over the land read)
// and, with a wind, windward over leeward median depth of valley cells.
void valley_depth_figures(const Grid& g, const Rays& rays, double wind_from_deg, LandformStats& s) {
  const int r = std::max(1, int(std::lround(kValleyDepthDiscShareOfDiameter * g.diameter_cells)));
  cv::Mat1f closed;
  cv::morphologyEx(g.h, closed, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}),
                   cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  // Bearing θ (clockwise from north, rows running south): the direction the
  // wind comes from is (sin θ, −cos θ) in (x, y).
  const double wx = std::sin(wind_from_deg * CV_PI / 180), wy = -std::cos(wind_from_deg * CV_PI / 180);
  std::vector<double> depth, windward, leeward;
  const double land_m = kValleyDepthLandShareOfPeak * g.peak_m, valley_m = kValleyCellShareOfPeak * g.peak_m;
  for (int y = 0; y < g.h.rows; ++y)
    for (int x = 0; x < g.h.cols; ++x) {
      if (!(g.h(y, x) > land_m)) continue;
      const double d = std::max(0.f, closed(y, x) - g.h(y, x));
      depth.push_back(d);
      if (wind_from_deg < 0 || d < valley_m) continue;
      const double facing = (x - rays.summit.x) * wx + (y - rays.summit.y) * wy;
      (facing > 0 ? windward : leeward).push_back(d);
    }
  if (!depth.empty()) {
    std::nth_element(depth.begin(), depth.begin() + long(depth.size() * 9 / 10), depth.end());
    s.valley_depth_p90_m = depth[depth.size() * 9 / 10];
  }
  if (!windward.empty() && !leeward.empty()) s.windward_depth_ratio = median_of(windward) / median_of(leeward);
}

}  // namespace

LandformStats landform_stats(const cv::Mat1f& height_m, double metres_per_px, double wind_from_deg) {
  if (height_m.empty()) throw Error("landform: empty height field");
  if (!(metres_per_px > 0)) throw Error("landform: metres_per_px must be > 0");
  if (!cv::checkRange(height_m)) throw Error("landform: the height field holds NaN or infinite values");
  const Grid g = landform_grid(height_m, metres_per_px);
  LandformStats s;
  s.cell_m = g.cell_m;
  cv::Mat1f smooth;
  const double sigma = std::max(1.0, kDetrendShareOfDiameter * g.diameter_cells);
  cv::GaussianBlur(g.h, smooth, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
  const cv::Mat1f detrended = g.h - smooth;
  const Rays rays = coast_rays(g, smooth, 720);
  circle_figures(g, rays, detrended, s);
  s.sector_cv = sector_dissection_cv(g, rays, detrended);
  drainage_figures(g, s);
  valley_depth_figures(g, rays, wind_from_deg, s);
  return s;
}

}  // namespace reefgen::terrain
