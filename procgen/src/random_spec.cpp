#include "reefgen/procgen/random_spec.hpp"

#include <algorithm>
#include <cmath>

#include "reefgen/terrain/noise.hpp"
#include "reefgen/rng.hpp"

namespace reefgen::procgen {

using terrain::GradientNoise2;
using terrain::NoiseTile;
using terrain::PeriodicNoise1;

std::vector<double> subsidence_levels(int count) {
  std::vector<double> out;
  if (count <= 1) return {0.0};
  for (int i = 0; i < count; ++i) out.push_back(static_cast<double>(i) / (count - 1));
  return out;
}

IslandSpec random_spec(uint64_t seed, uint64_t index, const RandomSpecParams& p) {
  Rng rng(seed, index, "island-config");
  IslandSpec s;
  const int K = p.control_radii;
  // Base radii of docs/DESIGN.md §4 (island, beach, lagoon, reef); the abyss outline
  // sits near the canvas edge.
  const double base[4] = {0.4, 0.4, 0.7, 0.8};
  // Island and beach share one centre shift so the beach surrounds the island.
  const double shift = rng.uniform(0, p.center_shift), shift_dir = rng.uniform(0, 2 * M_PI);
  for (int i = 0; i < 4; ++i) {
    const double f = rng.uniform(p.radius_scale_min, p.radius_scale_max);
    const PeriodicNoise1 wobble(rng.next_u64(), 3, 4);
    std::vector<double> radii(K);
    for (int k = 0; k < K; ++k) {
      const double theta = 2 * M_PI * k / K;
      double R = base[i] * f * (1.0 + p.outline_noise * wobble(static_cast<double>(k) / K));
      if (i < 2) {
        // Ray from the origin to a star-shaped curve of local radius R centred
        // `shift` away: r = d cos(θ−φ) + sqrt(R² − d² sin²(θ−φ)).
        const double d = std::min(shift, 0.8 * R), a = theta - shift_dir;
        R = d * std::cos(a) + std::sqrt(R * R - d * d * std::sin(a) * std::sin(a));
      }
      radii[k] = std::clamp(R, 0.02, 0.93);
    }
    s.outlines[i] = std::move(radii);
  }
  s.outlines[4] = {rng.uniform(0.96, 1.0)};

  // Profile and resistance × (1 + a·η(u)), a ~ U[0, max].
  for (auto* curve : {&s.profile, &s.resistance}) {
    const double a = rng.uniform(0, p.curve_noise_max);
    const PeriodicNoise1 eta(rng.next_u64(), 4, 3);
    const int N = static_cast<int>(curve->size());
    for (int j = 0; j < N; ++j)
      (*curve)[j] = std::clamp((*curve)[j] * (1.0 + a * eta(0.5 * j / (N - 1))), 0.0, 1.0);
  }

  // Wind: smoothed random walks.
  const int strokes = static_cast<int>(rng.uniform_int(p.strokes_min, p.strokes_max));
  for (int w = 0; w < strokes; ++w) {
    WindStroke st;
    const int npts = static_cast<int>(rng.uniform_int(p.stroke_points_min, p.stroke_points_max));
    double x = rng.uniform(-0.8, 0.8), y = rng.uniform(-0.8, 0.8), heading = rng.uniform(0, 2 * M_PI);
    const double step = rng.uniform(0.03, 0.07);
    std::vector<Vec2> walk;
    for (int k = 0; k < npts; ++k) {
      walk.push_back({x, y});
      heading += rng.uniform(-0.5, 0.5);  // persistent direction: a gust, not Brownian motion
      x = std::clamp(x + step * std::cos(heading), -1.2, 1.2);
      y = std::clamp(y + step * std::sin(heading), -1.2, 1.2);
    }
    // Smooth with a [1 2 1]/4 filter twice (end points kept).
    for (int pass = 0; pass < 2; ++pass) {
      auto prev = walk;
      for (int k = 1; k + 1 < npts; ++k) {
        walk[k].x = 0.25 * prev[k - 1].x + 0.5 * prev[k].x + 0.25 * prev[k + 1].x;
        walk[k].y = 0.25 * prev[k - 1].y + 0.5 * prev[k].y + 0.25 * prev[k + 1].y;
      }
    }
    st.points = std::move(walk);
    st.strength = rng.uniform(p.strength_min, p.strength_max);
    st.width = rng.uniform(p.width_min, p.width_max);
    s.wind.push_back(std::move(st));
  }
  s.noise.seed = rng.next_u64();
  return s;
}

}  // namespace reefgen::procgen
