#pragma once
// Small, deterministic noise functions of our own (no library, so the bytes
// are ours to keep stable across versions).
#include <array>
#include <cstdint>
#include <vector>

namespace reefgen::procgen {

// 2-D gradient noise (Perlin's improved noise, 12 gradient directions).
// perlin(): range [-1, 1] (clamped; typical |n| < 0.9), zero at lattice points,
// one feature per unit. fbm(): sum of `octaves` octaves (lacunarity 2, gain
// 0.5) divided by the sum of amplitudes, so also in [-1, 1].
class GradientNoise2 {
 public:
  explicit GradientNoise2(uint64_t seed);
  float perlin(float x, float y) const;
  float fbm(float x, float y, int octaves) const;

 private:
  std::array<uint8_t, 512> perm_;
};

// 1-D value-noise fBm on t in [0, 1), periodic with period 1 (for outlines in
// θ) or not (profile perturbation, where periodicity does no harm).
// `base_cells` lattice cells at the first octave, each octave doubles them.
// Range [-1, 1]; cubic (smoothstep) interpolation between lattice values.
class PeriodicNoise1 {
 public:
  PeriodicNoise1(uint64_t seed, int base_cells = 4, int octaves = 4);
  double operator()(double t) const;

 private:
  int base_cells_;
  std::vector<std::vector<double>> lattice_;  // one lattice per octave
};

}  // namespace reefgen::procgen
