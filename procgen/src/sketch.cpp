#include "reefgen/procgen/sketch.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "reefgen/files.hpp"

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

namespace {
enum class IslandKind { kYoung, kBarrier, kAtoll };

struct WorldIsland {
  double x_px, y_px, r_px, lambda;
  IslandKind kind;
  float noise_u, noise_v;  // the island's own offset into the noise
};

// The region of a bump value b (1 at the centre, 0 on the reef's outer edge).
uint8_t region_of(IslandKind kind, double b) {
  switch (kind) {
    case IslandKind::kYoung:
      return b > 0.3 ? kIsland : b > 0.22 ? kBeach : b > 0.12 ? kLagoon : b > 0 ? kReef : kAbyss;
    case IslandKind::kBarrier:
      return b > 0.72 ? kIsland : b > 0.62 ? kBeach : b > 0.2 ? kLagoon : b > 0 ? kReef : kAbyss;
    case IslandKind::kAtoll:
      // A ring: reef outside, islets (beach) on it, the lagoon inside.
      return b > 0.2 ? kLagoon : b > 0.11 ? kBeach : b > 0 ? kReef : kAbyss;
  }
  return kAbyss;
}

void check(const ArchipelagoParams& p) {
  if (p.width_px < 16 || p.width_px > 16384 || p.height_px < 16 || p.height_px > 16384)
    throw Error("sketch: an archipelago's width and height must be in [16, 16384]");
  if (p.islands < 1 || p.islands > 512) throw Error("sketch: an archipelago's islands must be in [1, 512]");
  if (!(p.metres_per_px > 0 && p.metres_per_px <= 1000)) throw Error("sketch: metres per pixel must be in (0, 1000]");
  if (!(p.min_radius_m > 0 && p.max_radius_m >= p.min_radius_m && std::isfinite(p.max_radius_m)))
    throw Error("sketch: island radii need 0 < min ≤ max");
  if (!(p.roughness >= 0 && p.roughness <= 1)) throw Error("sketch: roughness must be in [0, 1]");
  if (!(p.frequency > 0 && p.frequency <= 32)) throw Error("sketch: frequency must be in (0, 32]");
}

// Centres by rejection (64 tries, the one farthest from the others kept), so
// outlines rarely merge; centres may lie up to a third of a radius outside
// the canvas, and the second island is put on a border, so some cross it.
std::vector<WorldIsland> place_islands(const ArchipelagoParams& p, Rng& rng) {
  const double W = p.width_px, H = p.height_px;
  const double r_max = std::min(p.max_radius_m / p.metres_per_px, std::min(W, H) / 3);
  const double r_min = std::min(p.min_radius_m / p.metres_per_px, r_max);
  std::vector<double> radius(size_t(p.islands), r_max);
  for (size_t i = 1; i < radius.size(); ++i) radius[i] = r_min * std::exp(rng.uniform() * std::log(r_max / r_min));
  // A crowded sea merges its islands into one: while the islands' discs
  // (grown by the 1.3 spacing) would cover more than half of it, all but the
  // largest shrink (never below the smallest radius asked for).
  auto footprint = [&] {
    double a = 0;
    for (double r : radius) a += M_PI * (1.3 * r) * (1.3 * r);
    return a;
  };
  for (int k = 0; k < 32 && footprint() > 0.5 * W * H; ++k)
    for (size_t i = 1; i < radius.size(); ++i) radius[i] = std::max(r_min, 0.85 * radius[i]);
  std::vector<WorldIsland> out;
  for (int i = 0; i < p.islands; ++i) {
    const double r = radius[size_t(i)];
    WorldIsland best{};
    double best_gap = -1e18;
    for (int t = 0; t < 64; ++t) {
      WorldIsland c{rng.uniform(-r / 3, W + r / 3), rng.uniform(-r / 3, H + r / 3), r, 0, IslandKind::kYoung, 0, 0};
      if (i == 1 && rng.uniform() < 0.5) c.x_px = rng.uniform() < 0.5 ? 0.0 : W;
      else if (i == 1) c.y_px = rng.uniform() < 0.5 ? 0.0 : H;
      double gap = 1e18;
      for (const auto& o : out) gap = std::min(gap, std::hypot(c.x_px - o.x_px, c.y_px - o.y_px) - 1.3 * (c.r_px + o.r_px));
      if (gap > best_gap) best_gap = gap, best = c;
      if (gap > 0) break;
    }
    best.kind = IslandKind(i % 3);
    // The presets' subsidence (young-volcano 0, barrier-reef 0.3, atoll 0.9):
    // past ~0.4 the generator, and so the model, sinks the painted mountain.
    best.lambda = best.kind == IslandKind::kYoung     ? rng.uniform(0.0, 0.15)
                  : best.kind == IslandKind::kBarrier ? rng.uniform(0.25, 0.4)
                                                      : rng.uniform(0.85, 1.0);
    best.noise_u = float(rng.uniform(0, 4096));
    best.noise_v = float(rng.uniform(0, 4096));
    out.push_back(best);
  }
  return out;
}
}  // namespace

Sketch archipelago_sketch(const ArchipelagoParams& p, uint64_t seed) {
  check(p);
  Rng rng(derive_seed(seed, 0, "archipelago"));
  const std::vector<WorldIsland> isl = place_islands(p, rng);
  const GradientNoise2 noise(derive_seed(seed, 1, "archipelago-noise"));
  const int W = p.width_px, H = p.height_px;
  // Each cell keeps the island whose roughened bump is highest there; only
  // an island's box (its radius grown by the roughness) is visited.
  cv::Mat1f bump(H, W, 0.f);
  cv::Mat1i owner(H, W, -1);
  for (size_t i = 0; i < isl.size(); ++i) {
    const WorldIsland& w = isl[i];
    const double reach = w.r_px * (1 + p.roughness) + 1;
    // Octaves down to ~8 px features whatever the island's size (3 to 6).
    const int octaves = std::clamp(int(std::log2(w.r_px / 8)), 3, 6);
    const int x0 = std::max(0, int(w.x_px - reach)), x1 = std::min(W - 1, int(w.x_px + reach));
    const int y0 = std::max(0, int(w.y_px - reach)), y1 = std::min(H - 1, int(w.y_px + reach));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const double u = (x + 0.5 - w.x_px) / w.r_px, v = (y + 0.5 - w.y_px) / w.r_px;
        const double b = 1 - std::hypot(u, v) +
                         p.roughness * noise.fbm(float(u * p.frequency) + w.noise_u, float(v * p.frequency) + w.noise_v, octaves);
        if (b > bump(y, x)) bump(y, x) = float(b), owner(y, x) = int(i);
      }
  }
  Sketch s{cv::Mat1b(H, W, uint8_t(kAbyss)), cv::Mat1f(H, W, 0.f)};
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int i = owner(y, x);
      if (i < 0) continue;
      s.label(y, x) = region_of(isl[size_t(i)].kind, bump(y, x));
      if (s.label(y, x) != kAbyss) s.subsidence(y, x) = float(isl[size_t(i)].lambda);
    }
  return s;
}

}  // namespace reefgen::procgen
