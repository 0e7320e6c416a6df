#pragma once
// The curve-based generator (paper §4, DESIGN §3): outlines → parametric
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
};

struct IslandFields {
  cv::Mat1f height_m;  // W×W, metres, sea level 0, row 0 = top (+y)
  cv::Mat1f xt;        // W×W, parametric distance x̃ ∈ [0,5] after the wind warp
  cv::Mat1b label;     // W×W, region ids 0..4 = min(⌊x̃⌋, 4)
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

// Eq. 1: x̃ for radius r given the outer borders R[0..4] = R_1..R_5 (R_0 = 0).
double parametric_distance(double r, const std::array<double, 5>& R);

// atan2 with |error| < 2e-5 rad, ~4× faster than the libm call; used in the
// per-pixel loop where the outline tables have 6e-3 rad resolution anyway.
float fast_atan2(float y, float x);

// Outlines R_1..R_5 tabulated in θ, ordering R_{i+1} ≥ R_i + δ enforced on the
// evaluated curves (Catmull-Rom can overshoot between control radii).
class OutlineTable {
 public:
  static constexpr int kAngles = 2048;
  OutlineTable(const std::array<std::vector<double>, 5>& outlines, double min_gap);
  // x̃ at canvas point (x, y).
  float xt(float x, float y) const;
  std::array<double, 5> radii(double theta) const;

 private:
  std::vector<std::array<float, 5>> r_;  // kAngles + 1 rows (last = first, for wrap)
};

// Φ (Eq. 2, unnormalised Gaussian) at the (n+1)×(n+1) nodes x_i = −1 + 2i/n
// (row 0 = top, +y). Channel 0 = x, 1 = y (canvas units, +y up).
cv::Mat2f wind_field(const std::vector<WindStroke>& strokes, int n);

// Backward map after the sub-stepped semi-Lagrangian warp: for each node, the
// displacement D such that the material now at p came from p + D. `rho_of_xt`
// gives the resistance at parametric distance x̃.
cv::Mat2f integrate_warp(const cv::Mat2f& phi, const OutlineTable& outlines, const std::vector<float>& rho_lut,
                         int substeps);

}  // namespace reefgen::procgen
