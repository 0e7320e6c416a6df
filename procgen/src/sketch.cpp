#include "reefgen/procgen/sketch.hpp"

#include <cmath>
#include "reefgen/io.hpp"
#include <vector>

#include "reefgen/labels.hpp"
#include "reefgen/terrain/noise.hpp"
#include "reefgen/rng.hpp"

namespace reefgen::procgen {

using terrain::GradientNoise2;
using terrain::NoiseTile;

Sketch random_sketch(const SketchParams& p, uint64_t seed) {
  if (p.size_px < 16 || p.size_px > 4096) throw Error("sketch: size must be in [16, 4096]");
  if (p.islands < 1 || p.islands > 16) throw Error("sketch: islands must be in [1, 16]");
  if (!(p.subsidence == -1 || (p.subsidence >= 0 && p.subsidence <= 1)))
    throw Error("sketch: subsidence must be in [0, 1] (or -1 for random)");
  if (!(p.radius > 0 && p.radius <= 1)) throw Error("sketch: radius must be in (0, 1]");
  if (!(p.roughness >= 0 && p.roughness <= 1)) throw Error("sketch: roughness must be in [0, 1]");
  if (!(p.frequency > 0 && p.frequency <= 32)) throw Error("sketch: frequency must be in (0, 32]");

  Rng rng(derive_seed(seed, 0, "sketch"));
  struct Island {
    double x, y, r, lambda;
  };
  // Several islands: radius shrinks with sqrt(count) so their total area stays
  // about one island's; centres by rejection so outlines do not merge.
  std::vector<Island> isl;
  const double r = p.islands == 1 ? p.radius : p.radius / std::sqrt(double(p.islands)) * 1.2;
  for (int i = 0; i < p.islands; ++i) {
    Island best{0, 0, r, 0};
    double best_gap = -1e9;
    for (int t = 0; t < 64; ++t) {
      const double spread = p.islands == 1 ? 0.15 : std::max(0.0, 1.0 - r);
      const Island c{rng.uniform(-spread, spread), rng.uniform(-spread, spread), r * rng.uniform(0.8, 1.1), 0};
      double gap = 1e9;
      for (const auto& o : isl) gap = std::min(gap, std::hypot(c.x - o.x, c.y - o.y) - c.r - o.r);
      if (gap > best_gap) best_gap = gap, best = c;
      if (gap > 0.05) break;
    }
    best.lambda = p.subsidence >= 0 ? p.subsidence : rng.uniform();
    isl.push_back(best);
  }
  const GradientNoise2 noise(derive_seed(seed, 1, "sketch-noise"));
  const float ox = float(rng.uniform(0, 256)), oy = float(rng.uniform(0, 256));

  const int W = p.size_px;
  Sketch s{cv::Mat1b(W, W), cv::Mat1f(W, W)};
  for (int row = 0; row < W; ++row)
    for (int col = 0; col < W; ++col) {
      const double x = (col + 0.5) / W * 2 - 1, y = 1 - (row + 0.5) / W * 2;
      // Bump value b in (-inf, 1]: 1 at the centre, 0 on the reef's outer edge.
      double b = -1e9;
      size_t which = 0;
      for (size_t i = 0; i < isl.size(); ++i) {
        const double bi = 1 - std::hypot(x - isl[i].x, y - isl[i].y) / isl[i].r;
        if (bi > b) b = bi, which = i;
      }
      b += p.roughness * noise.fbm(float(x * p.frequency) + ox, float(y * p.frequency) + oy, 4);
      // Thresholds of the nested regions. A sunk island (λ -> 1) loses its
      // mountain and keeps a wide lagoon: an atoll.
      const double lam = isl[which].lambda;
      const double t_island = 0.62 + 0.4 * lam, t_beach = 0.5 + 0.12 * lam, t_lagoon = 0.3, t_reef = 0.0;
      uint8_t region = kAbyss;
      if (b > t_island) region = kIsland;
      else if (b > t_beach) region = kBeach;
      else if (b > t_lagoon) region = kLagoon;
      else if (b > t_reef) region = kReef;
      s.label(row, col) = region;
      s.subsidence(row, col) = float(lam);
    }
  return s;
}

}  // namespace reefgen::procgen
