#include "reefgen/procgen/curves.hpp"

#include <algorithm>
#include <cmath>

namespace reefgen::procgen {

double periodic_catmull_rom(const std::vector<double>& radii, double theta) {
  const int k = static_cast<int>(radii.size());
  if (k == 0) return 0;
  if (k == 1) return radii[0];
  double t = theta / (2 * M_PI);
  t = (t - std::floor(t)) * k;
  int i = static_cast<int>(std::floor(t));
  if (i >= k) i = k - 1;  // t == k after rounding
  const double f = t - i;
  auto at = [&](int j) { return radii[((j % k) + k) % k]; };
  return catmull_rom(at(i - 1), at(i), at(i + 1), at(i + 2), f);
}

std::vector<Vec2> sample_open_catmull_rom(const std::vector<Vec2>& pts, int per_segment) {
  std::vector<Vec2> out;
  const int n = static_cast<int>(pts.size());
  if (n == 0) return out;
  if (n == 1) return {pts[0]};
  per_segment = std::max(1, per_segment);
  out.reserve(static_cast<size_t>(n - 1) * per_segment + 1);
  auto at = [&](int j) { return pts[std::clamp(j, 0, n - 1)]; };
  for (int i = 0; i + 1 < n; ++i)
    for (int s = 0; s < per_segment; ++s) {
      const double t = static_cast<double>(s) / per_segment;
      out.push_back({catmull_rom(at(i - 1).x, at(i).x, at(i + 1).x, at(i + 2).x, t),
                     catmull_rom(at(i - 1).y, at(i).y, at(i + 1).y, at(i + 2).y, t)});
    }
  out.push_back(pts.back());
  return out;
}

double sample_curve(const std::vector<double>& s, double u) {
  const int n = static_cast<int>(s.size());
  if (n == 0) return 0;
  if (n == 1) return s[0];
  const double x = std::clamp(u, 0.0, 1.0) * (n - 1);
  const int i = std::min(static_cast<int>(x), n - 2);
  const double f = x - i;
  return s[i] + f * (s[i + 1] - s[i]);
}

}  // namespace reefgen::procgen
