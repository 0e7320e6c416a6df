#include "reefgen/terrain/rain.hpp"

#include <algorithm>
#include <cmath>
#include <complex>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/terrain/erosion.hpp"

namespace reefgen::terrain {

namespace {
constexpr double kSecondsPerYear = 3.15576e7;

// Angular wavenumber of DFT bin i of n cells of dx metres (negative above n/2).
double wavenumber(int i, int n, double dx) { return 2 * CV_PI * double(i <= n / 2 ? i : i - n) / (double(n) * dx); }

// Smith & Barstad's transfer function, Eq. 49: the rain's transform per unit
// of the terrain's, at wavenumbers (k, l) for a wind (u, v) m/s.
//   P̂/ĥ = C_w i σ / ((1 − i m H_w)(1 + i σ τ_c)(1 + i σ τ_f)),  σ = U k + V l,
//   m² = (N_m² − σ²)/σ² · (k² + l²); m real with σ's sign where σ² < N_m²
//   (waves that carry the lift aloft), i·√(−m²) where not (evanescent).
// The quotient as numerator × conj(denominator) / |denominator|²: one real
// division per bin (libgcc's guarded complex division was a tenth of the
// generator's time, docs/BENCHMARKS.md), accurate to double rounding here
// since every factor is within a few orders of magnitude of 1.
std::complex<double> transfer(double k, double l, double u, double v, const RainParams& p) {
  const double sigma = u * k + v * l;
  if (sigma == 0) return {0, 0};
  const double n2 = p.moist_stability_hz * p.moist_stability_hz, s2 = sigma * sigma;
  const double m2 = (n2 - s2) / s2 * (k * k + l * l);
  const std::complex<double> i(0, 1);
  const std::complex<double> m = m2 >= 0 ? std::complex<double>(std::copysign(std::sqrt(m2), sigma), 0)
                                         : std::complex<double>(0, std::sqrt(-m2));
  const std::complex<double> den =
      (1.0 - i * m * p.vapour_height_m) * std::complex<double>(1.0, sigma * p.condensation_s) *
      std::complex<double>(1.0, sigma * p.fallout_s);
  const std::complex<double> num(0, p.uplift_sensitivity * sigma);
  return num * std::conj(den) / std::norm(den);
}
}  // namespace

void to_json(nlohmann::json& j, const RainParams& p) { j = params_json(p); }

RainParams rain_params_from_json(const nlohmann::json& j, const std::string& origin) {
  return params_from_json<RainParams>(j, origin, "docs/EROSION.md", "rain.");
}

cv::Mat1f orographic_rain_mm_yr(const cv::Mat1f& height_m, double dx, cv::Vec2d wind_to, const RainParams& p) {
  if (height_m.empty()) throw Error("rain: empty height field");
  if (!(dx > 0)) throw Error("rain: metres_per_px must be > 0");
  const double speed = std::hypot(wind_to[0], wind_to[1]);
  if (!(speed > 0)) throw Error("rain: the wind's direction is a zero vector");
  const double u = p.wind_speed_m_s * wind_to[0] / speed, v = p.wind_speed_m_s * wind_to[1] / speed;
  // Terrain on a field twice the size (the sea lifts nothing). The DFT in
  // float: the rain's rounding is ~1e-6 of the terrain's largest term, far
  // below a mm/yr.
  const int H = cv::getOptimalDFTSize(2 * height_m.rows), W = cv::getOptimalDFTSize(2 * height_m.cols);
  cv::Mat1f terrain(H, W, 0.f);
  for (int y = 0; y < height_m.rows; ++y)
    for (int x = 0; x < height_m.cols; ++x) terrain(y, x) = std::max(0.f, height_m(y, x));
  cv::Mat spectrum;
  cv::dft(terrain, spectrum, cv::DFT_COMPLEX_OUTPUT);
  for (int r = 0; r < H; ++r) {
    const double l = wavenumber(r, H, dx);
    auto* row = spectrum.ptr<cv::Vec2f>(r);
    for (int c = 0; c < W; ++c) {
      const std::complex<double> z = transfer(wavenumber(c, W, dx), l, u, v, p) * std::complex<double>(row[c][0], row[c][1]);
      row[c] = cv::Vec2f(float(z.real()), float(z.imag()));
    }
  }
  cv::Mat1f rain;  // kg m⁻² s⁻¹ = mm/s
  cv::idft(spectrum, rain, cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
  cv::Mat1f out(height_m.size());
  const double floor = p.floor_share * p.background_mm_yr;
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x)
      out(y, x) = float(std::max(floor, p.background_mm_yr + double(rain(y, x)) * kSecondsPerYear));
  return out;
}

RainFields rain_for_erosion(const cv::Mat1f& height_m, double world_size_m, cv::Vec2d wind_to, const RainParams& p) {
  const int n = std::min(kRainGridPx, height_m.cols);
  const cv::Mat1f h = resampled(height_m, n, cv::INTER_AREA);
  const cv::Mat1f rain = orographic_rain_mm_yr(h, world_size_m / n, wind_to, p);
  const cv::Mat1f rel = runoff_relative_to_land_mean(rain, h, p.evapotranspiration_mm_yr);
  return {resampled(rain, height_m.cols, cv::INTER_LINEAR), resampled(rel, height_m.cols, cv::INTER_LINEAR)};
}

cv::Mat1f runoff_relative_to_land_mean(const cv::Mat1f& rain, const cv::Mat1f& h, double et_mm_yr) {
  cv::Mat1f runoff(rain.size());
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x)
      runoff(y, x) = float(std::max(double(rain(y, x)) - et_mm_yr, kMinRunoffShare * rain(y, x)));
  double sum = 0;
  int64_t n = 0;
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x)
      if (h(y, x) > 0) sum += runoff(y, x), ++n;
  if (n == 0 || !(sum > 0)) return cv::Mat1f(h.size(), 1.f);
  return cv::Mat1f(runoff * (double(n) / sum));
}

}  // namespace reefgen::terrain
