#pragma once
// The curves a user draws: closed outlines in polar form, open strokes in the
// plane, and 1-D profiles over the parametric distance.
#include <vector>

namespace reefgen::procgen {

struct Vec2 {
  double x = 0, y = 0;
};

// Uniform Catmull-Rom interpolation of p1..p2 at t in [0,1].
inline double catmull_rom(double p0, double p1, double p2, double p3, double t) {
  const double t2 = t * t, t3 = t2 * t;
  return 0.5 * ((2 * p1) + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t2 + (-p0 + 3 * p1 - 3 * p2 + p3) * t3);
}

// A closed outline r(θ): K control radii at θ_k = 2πk/K (θ = 0 is +x,
// counter-clockwise), interpolated by a periodic Catmull-Rom spline.
// One radius makes a circle.
double periodic_catmull_rom(const std::vector<double>& radii, double theta);

// An open Catmull-Rom curve through `points` (end points repeated), sampled
// with `per_segment` samples between consecutive control points. Returns the
// polyline including both end points.
std::vector<Vec2> sample_open_catmull_rom(const std::vector<Vec2>& points, int per_segment);

// Piecewise-linear curve through N ≥ 1 samples evenly spaced on u ∈ [0,1];
// clamped outside.
double sample_curve(const std::vector<double>& samples, double u);

}  // namespace reefgen::procgen
