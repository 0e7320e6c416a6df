#pragma once
// The standard normal distribution's quantile, shared by the stages that read
// a blurred mask as a distance (a blurred straight edge is Φ(x/σ)).
#include <algorithm>
#include <cmath>

namespace reefgen {

// Φ(x) = P(Z ≤ x) for a standard normal Z.
inline double normal_cdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

// Φ⁻¹(m) for m in (0, 1), to ~1e-12: Newton on Φ from a logistic start,
// kept inside a bracket that every step narrows, bisecting where Newton
// would leave it. Plain Newton from that start diverges in the tails (at
// m = 0.0012 it returned −1.2e12, and a coast's shoreface fell away there).
inline double normal_quantile(double m) {
  m = std::clamp(m, 1e-300, 1.0 - 1e-16);
  double lo = -40, hi = 40;
  double x = std::clamp(std::log(m / (1 - m)) / 1.702, lo, hi);
  for (int i = 0; i < 100; ++i) {
    const double f = normal_cdf(x) - m;
    if (f < 0) lo = x;
    else hi = x;
    const double pdf = std::exp(-0.5 * x * x) / std::sqrt(2 * M_PI);
    double next = pdf > 0 ? x - f / pdf : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - x) < 1e-13) return next;
    x = next;
  }
  return x;
}

}  // namespace reefgen
