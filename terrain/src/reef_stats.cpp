#include "reefgen/terrain/reef_stats.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/stats.hpp"

namespace reefgen::terrain {

namespace {

// Bilinear height at (x, y) pixels, or NaN off the field.
double at(const cv::Mat1f& h, double x, double y) {
  if (x < 0 || y < 0 || x > h.cols - 1 || y > h.rows - 1) return NAN;
  const int ix = std::min(int(x), h.cols - 2), iy = std::min(int(y), h.rows - 2);
  const double fx = x - ix, fy = y - iy;
  const double a = h(iy, ix) + fx * (h(iy, ix + 1) - h(iy, ix));
  const double b = h(iy + 1, ix) + fx * (h(iy + 1, ix + 1) - h(iy + 1, ix));
  return a + fy * (b - a);
}

// The island's centre: the mean position of the cells above kReefEdgeM.
cv::Point2d reef_centre(const cv::Mat1f& h) {
  double sx = 0, sy = 0, n = 0;
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x)
      if (h(y, x) > kReefEdgeM) sx += x, sy += y, n += 1;
  return n > 0 ? cv::Point2d(sx / n, sy / n) : cv::Point2d(0.5 * (h.cols - 1), 0.5 * (h.rows - 1));
}

struct Ray {
  bool reef = false;
  double crest_m = NAN, flat_width_m = NAN;
  std::vector<double> lagoon;  // water heights inward of the crest, before land
};

// One ray from the centre: the crest in the band inward of the reef's outer
// edge, the flat around it, the lagoon inward of it.
Ray cast_ray(const cv::Mat1f& h, cv::Point2d c, double angle, double mpp) {
  Ray r;
  const double dx = std::cos(angle), dy = std::sin(angle);
  std::vector<double> prof;
  for (double s = 0;; s += 1.0) {
    const double v = at(h, c.x + s * dx, c.y + s * dy);
    if (std::isnan(v)) break;
    prof.push_back(v);
  }
  int edge = -1;
  for (int i = int(prof.size()) - 1; i >= 0; --i)
    if (prof[size_t(i)] > kReefEdgeM) { edge = i; break; }
  if (edge < 0) return r;
  r.reef = true;
  const int band = std::max(1, int(kReefBandM / mpp));
  // Inward no further than the first land (above the sea, 0 m): on a
  // fringing reef the island's beach lies within the band, and it is not
  // the reef's crest, which is awash (a ray whose edge is land keeps it).
  int ci = edge;
  for (int i = edge; i >= std::max(0, edge - band); --i) {
    if (prof[size_t(i)] > 0 && i != edge) break;
    if (prof[size_t(i)] > prof[size_t(ci)]) ci = i;
  }
  r.crest_m = prof[size_t(ci)];
  int a = ci, b = ci;
  auto flat = [&](int i) { return prof[size_t(i)] >= -2.0 && prof[size_t(i)] <= 1.0; };
  if (flat(ci)) {
    while (a > 0 && flat(a - 1)) --a;
    while (b + 1 < int(prof.size()) && flat(b + 1)) ++b;
    r.flat_width_m = (b - a + 1) * mpp;
  }
  // The lagoon: inward of the flat, water cells until the first land.
  for (int i = a - 1; i >= 0; --i) {
    if (prof[size_t(i)] >= 0) break;
    r.lagoon.push_back(prof[size_t(i)]);
  }
  return r;
}

// Runs of pass rays (crest < kPassCrestM) between reef rays, round the
// circle; runs closer than kPassMergeRays (a pass's rough walls) are one.
constexpr int kPassMergeRays = 4;
int count_passes(const std::vector<Ray>& rays) {
  std::vector<int> state;  // over the rays that cross a reef: 1 pass, 0 rim
  for (const Ray& r : rays)
    if (r.reef) state.push_back(r.crest_m < kPassCrestM ? 1 : 0);
  const int n = int(state.size());
  int start = -1;
  for (int i = 0; i < n; ++i)
    if (state[size_t(i)] == 0) { start = i; break; }
  if (start < 0) return 0;
  // Walk once round from a rim ray; a rim run shorter than kPassMergeRays
  // between two pass rays does not end the pass.
  int passes = 0, rim_run = kPassMergeRays;
  for (int k = 1; k <= n; ++k) {
    if (state[size_t((start + k) % n)] == 1) {
      if (rim_run >= kPassMergeRays) ++passes;
      rim_run = 0;
    } else {
      ++rim_run;
    }
  }
  return passes;
}

void measure_motu(const cv::Mat1f& h, double mpp, ReefStats& st) {
  cv::Mat1b land = h > 0.f;
  cv::Mat labels;
  const int n = cv::connectedComponents(land, labels, 8, CV_32S);
  std::vector<float> top(size_t(n), -1e30f);
  std::vector<std::vector<cv::Point>> pts(static_cast<size_t>(n) + 0);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      const int l = labels.at<int>(y, x);
      if (l == 0) continue;
      top[size_t(l)] = std::max(top[size_t(l)], h(y, x));
      pts[size_t(l)].push_back({x, y});
    }
  for (int l = 1; l < n; ++l) {
    if (top[size_t(l)] >= kMotuMaxHeightM) continue;
    const cv::RotatedRect box = cv::minAreaRect(pts[size_t(l)]);
    st.motu_widths_m.push_back((std::min(box.size.width, box.size.height) + 1.0) * mpp);
  }
  st.motu = int(st.motu_widths_m.size());
}

// Welch's method: the amplitude spectra of every window that lies ≥ 90 % on
// underwater slope (−80 … −3 m), Hann-windowed after the window's plane is
// removed, averaged; the grid's components read off the mean spectrum at
// period P along x, y and the diagonals. Windows are 8 periods wide (a power
// of two, ≥ 32 px): narrow enough to fit on a reef island's flank.
void measure_grid(const cv::Mat1f& h, double period_px, ReefStats& st) {
  int n = 32;
  while (n < 8 * period_px) n *= 2;
  if (h.rows < n || h.cols < n || period_px * 2 > n) return;
  std::vector<double> hann(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) hann[size_t(i)] = 0.5 - 0.5 * std::cos(2.0 * M_PI * (i + 0.5) / n);
  double hann_sum = 0;
  for (double a : hann) hann_sum += a;
  cv::Mat1d mean_amp(n, n, 0.0);
  int windows = 0;
  for (int y0 = 0; y0 + n <= h.rows; y0 += n / 2)
    for (int x0 = 0; x0 + n <= h.cols; x0 += n / 2) {
      const cv::Mat1f w = h(cv::Rect(x0, y0, n, n));
      if (cv::countNonZero((w > -80.f) & (w < -3.f)) < n * n) continue;  // slope only: land keeps its own detail
      // Remove the window's least-squares plane (mean and the two slopes).
      double m = cv::mean(w)[0], sx = 0, sy = 0, c = 0;
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const double u = x - 0.5 * (n - 1), v = y - 0.5 * (n - 1);
          sx += u * (w(y, x) - m), sy += v * (w(y, x) - m), c += u * u;
        }
      cv::Mat1f d(n, n);
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const double u = x - 0.5 * (n - 1), v = y - 0.5 * (n - 1);
          d(y, x) = float((w(y, x) - m - sx / c * u - sy / c * v) * hann[size_t(x)] * hann[size_t(y)]);
        }
      cv::Mat spec;
      cv::dft(d, spec, cv::DFT_COMPLEX_OUTPUT);
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const cv::Vec2f z = spec.at<cv::Vec2f>(y, x);
          mean_amp(y, x) += 2.0 * std::hypot(z[0], z[1]) / (hann_sum * hann_sum);
        }
      ++windows;
    }
  if (windows == 0) return;
  mean_amp /= windows;
  auto amp = [&](int u, int v) { return mean_amp((v + n) % n, (u + n) % n); };
  const int k = int(std::lround(n / period_px));
  const double peak = std::max({amp(k, 0), amp(0, k), amp(k, k), amp(k, -k)});
  std::vector<double> ring;
  for (int v = -k - 2; v <= k + 2; ++v)
    for (int u = -k - 2; u <= k + 2; ++u) {
      const double r = std::hypot(u, v);
      if (std::fabs(r - k) <= 2.0 && !(std::abs(u) <= 1 || std::abs(v) <= 1 || std::abs(std::abs(u) - std::abs(v)) <= 1))
        ring.push_back(amp(u, v));
    }
  st.grid_amplitude_m = peak;
  const double med = median(ring);
  st.grid_ring_ratio = med > 0 ? peak / med : NAN;
}

}  // namespace

ReefStats reef_stats(const cv::Mat1f& h, double mpp, double grid_period_px) {
  if (h.empty() || h.rows < 2 || h.cols < 2) throw Error("reef statistics need a height field of at least 2×2");
  if (!(mpp > 0) || !std::isfinite(mpp)) throw Error("reef statistics need a positive cell size");
  ReefStats st;
  const cv::Point2d c = reef_centre(h);
  std::vector<Ray> rays;
  std::vector<double> crests, flats, lagoon;
  int at_sea = 0;
  for (int i = 0; i < kReefRays; ++i) {
    rays.push_back(cast_ray(h, c, 2.0 * M_PI * i / kReefRays, mpp));
    const Ray& r = rays.back();
    if (!r.reef) continue;
    ++st.rays_with_reef;
    crests.push_back(r.crest_m);
    at_sea += r.crest_m >= kCrestAtSeaM;
    if (!std::isnan(r.flat_width_m)) flats.push_back(r.flat_width_m);
    lagoon.insert(lagoon.end(), r.lagoon.begin(), r.lagoon.end());
  }
  if (st.rays_with_reef > 0) st.crest_at_sea = double(at_sea) / st.rays_with_reef;
  st.crest_median_m = median(crests);
  st.reef_flat_width_m = median(flats);
  st.lagoon_median_m = median(lagoon);
  if (!lagoon.empty()) st.lagoon_min_m = *std::min_element(lagoon.begin(), lagoon.end());
  st.passes = count_passes(rays);
  measure_motu(h, mpp, st);
  double lo = 0;
  cv::minMaxLoc(h, &lo);
  st.flat_floor_share = double(cv::countNonZero(h < float(lo + 0.5))) / double(h.total());
  if (grid_period_px > 0) measure_grid(h, grid_period_px, st);
  return st;
}

}  // namespace reefgen::terrain
