#pragma once
// Small statistics shared by the benchmarks and the evaluations.
#include <algorithm>
#include <cmath>
#include <vector>

namespace reefgen {

// The median: the middle value, or the mean of the two middle values of an
// even count (14 painted sketches: the 7th and 8th); NaN when empty.
inline double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  const size_t n = v.size(), h = n / 2;
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(h), v.end());
  const double hi = v[h];
  if (n % 2 == 1) return hi;
  return 0.5 * (*std::max_element(v.begin(), v.begin() + std::ptrdiff_t(h)) + hi);
}

}  // namespace reefgen
