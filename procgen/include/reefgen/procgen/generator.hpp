#pragma once
// The curve-based generator (paper §4, docs/DESIGN.md §3): outlines → parametric
// distance x̃ → profile heights, wind warp, subsidence, coral, smooth max.
#include <array>
#include <vector>

#include <opencv2/core.hpp>

#include "reefgen/procgen/spec.hpp"

namespace reefgen::procgen {

struct RenderOptions {
  int size_px = 256;   // W, output is W×W pixels covering [-1,1]², [8, 8192]
  int warp_grid = 64;  // cells across the canvas of the displacement field, [4, 1024]; the
                       // wind field is smooth at this scale (σ ≥ 0.1 ≈ 3 cells) so the
                       // warp is integrated there and interpolated to pixels
  int resistance_grid = 128;  // cells across the canvas of the sampled resistance ρ(x̃), [4, 4096]
  bool keep_uneroded = false;  // also return the heights before erosion (IslandFields::uneroded_m: wear and deposit layers)
  int wind_grid = 32;  // cells across the canvas at which Φ is evaluated exactly, [4, 1024];
                       // Φ is a sum of Gaussians of σ ≥ 0.1 (1.6 cells), interpolated to
                       // the warp grid. The closest-point search is the costly part.
};

struct IslandFields {
  cv::Mat1f height_m;  // W×W, metres, sea level 0, row 0 = top (+y)
  cv::Mat1f xt;        // W×W, parametric distance x̃ ∈ [0,5] after the wind warp
  cv::Mat1b label;     // W×W, region ids 0..4 = min(⌊x̃⌋, 4)
  cv::Mat1f uneroded_m;  // W×W heights before erosion (coral included) when RenderOptions::keep_uneroded; else empty
  cv::Mat1f rain_mm_yr;  // W×W rain from the prevailing wind the erosion read (terrain/rain.hpp), mm/yr; empty without wind, rain or erosion
};

IslandFields generate(const IslandSpec& spec, const RenderOptions& opt = {});

// ---- Pure pieces (exposed for tests and for other stages) ----

// The authors' smooth maximum (Eq. 9): max(a,b) + δ/(e^{2kδ} − 1), δ = |a−b|;
// tends to max(a,b) + 1/(2k) at a = b (handled without 0/0).
double smax(double a, double b, double k);

// Coral height (Eqs. 6-8) at x = x̃ − 3.
double coral_height_m(double x, const CoralParams& c);

// M: normalised profile value → metres (monotone, piecewise linear).
double profile_to_metres(double p, const HeightMapping& m);

// Eq. 5 in profile space: M((1 − λ)·p0).
inline double subsided_height_m(double p0, double lambda, const HeightMapping& m) {
  return profile_to_metres((1.0 - lambda) * p0, m);
}

// smax() with the correction δ/(e^{2kδ}−1) read from a table over t = 2kδ
// (|error| < 1e-4 m for k ≥ 0.01 1/m): one exp per pixel was 10 % of an island.
class SmoothMaxTable {
 public:
  explicit SmoothMaxTable(double k);
  float operator()(float a, float b) const {
    const float m = a > b ? a : b, d = a > b ? a - b : b - a;
    const float t = d * scale_;  // table index: 2kδ · kPerUnit
    if (t >= static_cast<float>(kMaxT * kPerUnit)) return m;
    const int i = static_cast<int>(t);
    const float f = t - static_cast<float>(i);
    return m + c_[i] + f * (c_[i + 1] - c_[i]);
  }

 private:
  static constexpr int kMaxT = 40;  // beyond t = 40 the correction is < 2e-16 m
  static constexpr int kPerUnit = 64;
  float scale_;                     // 2k · kPerUnit
  std::vector<float> c_;
};

// Eq. 1: x̃ for radius r given the outer borders R[0..4] = R_1..R_5 (R_0 = 0).
double parametric_distance(double r, const std::array<double, 5>& R);

// atan2 with |error| < 2e-5 rad, ~4× faster than the libm call; used in the
// per-pixel loop where the outline tables have 6e-3 rad resolution anyway.
float fast_atan2(float y, float x);

// Outlines R_1..R_5 tabulated in θ, ordering R_{i+1} ≥ R_i + δ enforced on the
// evaluated curves (Catmull-Rom can overshoot between control radii).
class OutlineTable {
 public:
  static constexpr int kAngles = 1024;  // 6e-3 rad: < 1 px at r = 1 up to W = 1024
  OutlineTable(const std::array<std::vector<double>, 5>& outlines, double min_gap);
  // x̃ at canvas point (x, y).
  float xt(float x, float y) const;
  // out[p] = xt(x[p], y[p]) for p < n, bit for bit, on the CPU's vector path
  // (docs/BENCHMARKS.md, "Vector paths"; REEFGEN_CPU_PATH forces a smaller one).
  void xt_row(const float* x, const float* y, int n, float* out) const;
  std::array<double, 5> radii(double theta) const;

 private:
  std::vector<std::array<float, 5>> r_;  // kAngles + 1 rows (last = first, for wrap)
  float outer2_;                         // (max R_5)²: beyond it x̃ = 5 without an atan2
};

// Φ (Eq. 2, unnormalised Gaussian) at the (n+1)×(n+1) nodes x_i = −1 + 2i/n
// (row 0 = top, +y). Channel 0 = x, 1 = y (canvas units, +y up).
cv::Mat2f wind_field(const std::vector<WindStroke>& strokes, int n);

// ρ(x̃(p)) at the (m+1)² nodes x_i = −1 + 2i/m: the resistance of the
// unwarped island, sampled once so that the sub-steps pay a bilinear look-up
// instead of an atan2 and an outline search per node and step.
cv::Mat1f resistance_field(const OutlineTable& outlines, const std::vector<float>& rho_of_xt, int m);

// Backward map after the sub-stepped semi-Lagrangian warp (docs/DESIGN.md §3): for
// each node p of `phi`'s grid, the displacement D such that the material now
// at p came from p + D. Each step moves material by (1 − ρ)Φ/substeps, ρ read
// where that material started (it is advected with the heights and x̃).
cv::Mat2f integrate_warp(const cv::Mat2f& phi, const cv::Mat1f& resistance, int substeps);

}  // namespace reefgen::procgen
