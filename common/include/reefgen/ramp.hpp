#pragma once
// Smooth ramps shared by the stages.
#include <algorithm>

namespace reefgen {

// The smoothstep cubic 3t² − 2t³ of t in [0, 1], C¹ at both ends, in t's
// own precision: what eases a weight in without a kink where it begins.
template <class T>
inline T smoothstep(T t) {
  return t * t * (T(3) - T(2) * t);
}

// 0 at or below a, 1 at or above b, C¹ in between (the smoothstep cubic).
inline float ramp(double a, double b, double x) {
  return float(smoothstep(std::clamp((x - a) / (b - a), 0.0, 1.0)));
}

}  // namespace reefgen
