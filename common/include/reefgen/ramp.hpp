#pragma once
// Smooth ramps shared by the stages.
#include <algorithm>

namespace reefgen {

// 0 at or below a, 1 at or above b, C¹ in between (the smoothstep cubic).
inline float ramp(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return float(t * t * (3 - 2 * t));
}

}  // namespace reefgen
