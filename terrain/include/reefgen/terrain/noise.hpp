#pragma once
// Small, deterministic noise functions of our own (no library, so the bytes
// are ours to keep stable across versions).
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

namespace reefgen::terrain {

// 2-D gradient noise (Perlin's improved noise, 12 gradient directions).
// perlin(): range [-1, 1] (clamped; typical |n| < 0.9), zero at lattice points,
// one feature per unit. fbm(): sum of `octaves` octaves (lacunarity 2, gain
// 0.5) divided by the sum of amplitudes, so also in [-1, 1].
class GradientNoise2 {
 public:
  explicit GradientNoise2(uint64_t seed);
  float perlin(float x, float y) const;
  float fbm(float x, float y, int octaves) const;
  // fbm at n points, out[i] = fbm(x[i], y[i], octaves) to the bit, eight
  // points at a time on the AVX2 and AVX-512 paths (reefgen/vector_path.hpp;
  // docs/BENCHMARKS.md): for loops that read the noise at every cell.
  void fbm_n(const float* x, const float* y, int n, int octaves, float* out) const;
  // Same noise with the lattice wrapped every `period` cells; `salt` shifts
  // the hash so that octaves are not copies of each other.
  float perlin_periodic(float x, float y, int period, int salt) const;
  // perlin_periodic at n points, to the bit; on the vector path when the
  // period is a power of two.
  void perlin_periodic_n(const float* x, const float* y, int n, int period, int salt, float* out) const;

 private:
  std::array<uint8_t, 512> perm_;
  // perm_ widened, for the vector path's gathers.
  std::array<int32_t, 512> perm32_;
 public:
  using FbmRowFn = void (*)(const GradientNoise2&, const int32_t*, const float*, const float*, int, int, float*);

 private:
  // fbm_n's loop for the CPU path when the noise was made (REEFGEN_CPU_PATH
  // caps it, as every dispatched loop).
  FbmRowFn fbm_row_;
};

// A periodic fBm texture of kSize² texels (Perlin octaves with lattice cells
// of 8, 4, 2, 1 texels), built once per process and shared by all threads.
// Per-pixel gradient noise costs ~15 ns an octave; a bilinear look-up into
// this tile costs ~3 ns, which is what keeps detail noise inside the per-island
// budget. Islands sample it at a seed-dependent offset and orientation; one
// period holds 64 base features, more than a canvas shows (50 at W/50).
class NoiseTile {
 public:
  static constexpr int kSize = 512;       // texels, power of two
  static constexpr int kBaseCell = 8;     // texels per base feature
  static constexpr int kMaxOctaves = 4;
  // The shared tile with `octaves` ∈ [1, 4] octaves (clamped). Range [-1, 1].
  static const NoiseTile& get(int octaves);
  // Bilinear, wrapping look-up at texel coordinates (u, v).
  float sample(float u, float v) const {
    // floor by truncation and correction: std::floor is a libm call on
    // baseline x86-64 (no SSE4.1), and this runs once per pixel.
    int iu = static_cast<int>(u), iv = static_cast<int>(v);
    iu -= u < static_cast<float>(iu);
    iv -= v < static_cast<float>(iv);
    const float fu = static_cast<float>(iu), fv = static_cast<float>(iv);
    iu &= kSize - 1;
    iv &= kSize - 1;
    const int iu1 = (iu + 1) & (kSize - 1), iv1 = (iv + 1) & (kSize - 1);
    const float a = u - fu, b = v - fv;
    const float* r0 = &t_[static_cast<size_t>(iv) * kSize];
    const float* r1 = &t_[static_cast<size_t>(iv1) * kSize];
    const float top = r0[iu] + a * (r0[iu1] - r0[iu]);
    const float bot = r1[iu] + a * (r1[iu1] - r1[iu]);
    return top + b * (bot - top);
  }
  // Catmull-Rom (bicubic) look-up: C¹ across texel edges. Bilinear look-up
  // has a kink on every texel edge; once a texel spans several pixels
  // (magnified: a 4097² island samples the tile at ~10 px per texel) the kinks
  // show in a hill-shade as a grid of straight creases. 16 taps instead of 4.
  float sample_cubic(float u, float v) const {
    int iu = static_cast<int>(u), iv = static_cast<int>(v);
    iu -= u < static_cast<float>(iu);
    iv -= v < static_cast<float>(iv);
    const float a = u - static_cast<float>(iu), b = v - static_cast<float>(iv);
    float wu[4], wv[4];
    catmull_rom(a, wu);
    catmull_rom(b, wv);
    float sum = 0;
    for (int j = 0; j < 4; ++j) {
      const float* r = &t_[static_cast<size_t>((iv - 1 + j) & (kSize - 1)) * kSize];
      float row = 0;
      for (int i = 0; i < 4; ++i) row += wu[i] * r[(iu - 1 + i) & (kSize - 1)];
      sum += wv[j] * row;
    }
    return sum;
  }

 private:
  static void catmull_rom(float t, float w[4]) {
    const float t2 = t * t, t3 = t2 * t;
    w[0] = 0.5f * (-t3 + 2 * t2 - t);
    w[1] = 0.5f * (3 * t3 - 5 * t2 + 2);
    w[2] = 0.5f * (-3 * t3 + 4 * t2 + t);
    w[3] = 0.5f * (t3 - t2);
  }
  explicit NoiseTile(int octaves);
  std::vector<float> t_;
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

}  // namespace reefgen::terrain
