#include "reefgen/terrain/noise.hpp"

#include <algorithm>
#include <cmath>

#include "reefgen/rng.hpp"

namespace reefgen::terrain {

GradientNoise2::GradientNoise2(uint64_t seed) {
  std::array<uint8_t, 256> p;
  for (int i = 0; i < 256; ++i) p[i] = static_cast<uint8_t>(i);
  Rng rng(seed, 0, "gradient-noise-2d");
  for (int i = 255; i > 0; --i) std::swap(p[i], p[rng.uniform_int(0, i)]);  // Fisher-Yates
  for (int i = 0; i < 512; ++i) perm_[i] = p[i & 255];
}

namespace {
inline float fade(float t) { return t * t * t * (t * (t * 6.f - 15.f) + 10.f); }
inline float lerp(float a, float b, float t) { return a + t * (b - a); }
// 12 directions of Perlin's improved noise restricted to 2-D (z = 0), plus 4
// repeats so that a hash & 15 picks uniformly enough: h → (g_x, g_y), the
// gradient dotted with (x, y). Read from a table rather than a switch (a
// jump per lattice corner was a third of the generator's noise time); the
// products by 1 and 0 are exact, so the values are the switch's.
constexpr float kGradX[16] = {1, -1, 1, -1, 1, -1, 0, 0, 1, -1, 0, 0, 1, 0, -1, 0};
constexpr float kGradY[16] = {1, 1, -1, -1, 0, 0, 1, -1, 0, 0, 1, -1, 1, 1, 1, -1};
inline float grad(uint8_t h, float x, float y) { return kGradX[h & 15] * x + kGradY[h & 15] * y; }
}  // namespace

float GradientNoise2::perlin(float x, float y) const {
  const float fx = std::floor(x), fy = std::floor(y);
  const int X = static_cast<int>(fx) & 255, Y = static_cast<int>(fy) & 255;
  x -= fx; y -= fy;
  const float u = fade(x), v = fade(y);
  const int a = perm_[X] + Y, b = perm_[X + 1] + Y;
  const float n = lerp(lerp(grad(perm_[a], x, y), grad(perm_[b], x - 1, y), u),
                       lerp(grad(perm_[a + 1], x, y - 1), grad(perm_[b + 1], x - 1, y - 1), u), v);
  return std::clamp(n, -1.f, 1.f);
}

float GradientNoise2::perlin_periodic(float x, float y, int period, int salt) const {
  const float fx = std::floor(x), fy = std::floor(y);
  const int X0 = static_cast<int>(fx), Y0 = static_cast<int>(fy);
  auto wrap = [period, salt](int i) { return (((i % period) + period) % period + 37 * salt) & 255; };
  const int X = wrap(X0), X1 = wrap(X0 + 1), Y = wrap(Y0), Y1 = wrap(Y0 + 1);
  x -= fx; y -= fy;
  const float u = fade(x), v = fade(y);
  auto h = [this](int i, int j) { return perm_[perm_[i] + j]; };
  const float n = lerp(lerp(grad(h(X, Y), x, y), grad(h(X1, Y), x - 1, y), u),
                       lerp(grad(h(X, Y1), x, y - 1), grad(h(X1, Y1), x - 1, y - 1), u), v);
  return std::clamp(n, -1.f, 1.f);
}

float GradientNoise2::fbm(float x, float y, int octaves) const {
  float sum = 0, amp = 1, norm = 0;
  for (int o = 0; o < octaves; ++o) {
    // Offsetting each octave decorrelates the zeros at lattice points.
    sum += amp * perlin(x + 17.31f * o, y - 9.73f * o);
    norm += amp;
    amp *= 0.5f;
    x *= 2; y *= 2;
  }
  return sum / norm;
}

NoiseTile::NoiseTile(int octaves) : t_(static_cast<size_t>(kSize) * kSize) {
  // Periodic Perlin: lattice indices wrap at the period (in cells) of each
  // octave, so the tile repeats seamlessly. Fixed seed: the tile is part of
  // the generator's definition, islands differ by where they sample it.
  const GradientNoise2 g(0x5EEDu);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      float sum = 0, amp = 1, norm = 0;
      int cell = kBaseCell;
      for (int o = 0; o < octaves; ++o, cell /= 2) {
        const int period = kSize / cell;
        const float u = float(x) / cell, v = float(y) / cell;
        sum += amp * g.perlin_periodic(u + 0.5f / cell, v + 0.5f / cell, period, o);
        norm += amp;
        amp *= 0.5f;
      }
      t_[static_cast<size_t>(y) * kSize + x] = sum / norm;
    }
}

const NoiseTile& NoiseTile::get(int octaves) {
  octaves = std::clamp(octaves, 1, kMaxOctaves);
  // Function-local statics: each built on first use, thread-safe (C++11).
  switch (octaves) {
    case 1: { static const NoiseTile t(1); return t; }
    case 2: { static const NoiseTile t(2); return t; }
    case 3: { static const NoiseTile t(3); return t; }
    default: { static const NoiseTile t(4); return t; }
  }
}

PeriodicNoise1::PeriodicNoise1(uint64_t seed, int base_cells, int octaves) : base_cells_(std::max(1, base_cells)) {
  Rng rng(seed, 0, "periodic-noise-1d");
  for (int o = 0; o < std::max(1, octaves); ++o) {
    std::vector<double> lat(static_cast<size_t>(base_cells_) << o);
    for (auto& v : lat) v = rng.uniform(-1.0, 1.0);
    lattice_.push_back(std::move(lat));
  }
}

double PeriodicNoise1::operator()(double t) const {
  double sum = 0, amp = 1, norm = 0;
  for (const auto& lat : lattice_) {
    const int n = static_cast<int>(lat.size());
    const double x = (t - std::floor(t)) * n;
    const int i0 = static_cast<int>(std::floor(x)) % n;
    const int i1 = (i0 + 1) % n;
    const double f = x - std::floor(x);
    const double s = f * f * (3 - 2 * f);
    sum += amp * (lat[i0] + s * (lat[i1] - lat[i0]));
    norm += amp;
    amp *= 0.5;
  }
  return sum / norm;
}

}  // namespace reefgen::terrain
