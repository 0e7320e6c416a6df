#include "reefgen/ramp.hpp"
#include "reefgen/terrain/noise.hpp"

#include <algorithm>
#include <cmath>

#include <immintrin.h>

#include "reefgen/rng.hpp"
#include "reefgen/vector_path.hpp"

namespace reefgen::terrain {

namespace {
GradientNoise2::FbmRowFn fbm_row_for_this_cpu();
}  // namespace

GradientNoise2::GradientNoise2(uint64_t seed) : fbm_row_(fbm_row_for_this_cpu()) {
  std::array<uint8_t, 256> p;
  for (int i = 0; i < 256; ++i) p[i] = static_cast<uint8_t>(i);
  Rng rng(seed, 0, "gradient-noise-2d");
  for (int i = 255; i > 0; --i) std::swap(p[i], p[rng.uniform_int(0, i)]);  // Fisher-Yates
  for (int i = 0; i < 512; ++i) perm_[i] = p[i & 255], perm32_[i] = p[i & 255];
}

namespace {
// fade, lerp and grad are mirrored operation for operation by fbm_n's vector
// path below (the same roundings in the same order: the same bits).
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

namespace {

// Eight lanes of perlin(): floor, the lattice hash by gathers from perm32,
// fade, the four corner gradients and the lerps, each rounded as the scalar
// code rounds it (no FMA: the build has -ffp-contract=off and no target here
// enables it).
struct Perlin8 {
  const int32_t* perm;

  REEFGEN_AVX2 static __m256 fade8(__m256 t) {
    const __m256 t3 = _mm256_mul_ps(_mm256_mul_ps(t, t), t);
    __m256 b = _mm256_sub_ps(_mm256_mul_ps(t, _mm256_set1_ps(6.f)), _mm256_set1_ps(15.f));
    b = _mm256_add_ps(_mm256_mul_ps(t, b), _mm256_set1_ps(10.f));
    return _mm256_mul_ps(t3, b);
  }
  REEFGEN_AVX2 static __m256 lerp8(__m256 a, __m256 b, __m256 t) {
    return _mm256_add_ps(a, _mm256_mul_ps(t, _mm256_sub_ps(b, a)));
  }
  REEFGEN_AVX2 static __m256 grad8(__m256i h, __m256 x, __m256 y) {
    const __m256i i = _mm256_and_si256(h, _mm256_set1_epi32(15));
    const __m256 gx = _mm256_i32gather_ps(kGradX, i, 4), gy = _mm256_i32gather_ps(kGradY, i, 4);
    return _mm256_add_ps(_mm256_mul_ps(gx, x), _mm256_mul_ps(gy, y));
  }
  REEFGEN_AVX2 __m256i hash(__m256i i) const { return _mm256_i32gather_epi32(perm, i, 4); }
  REEFGEN_AVX2 __m256i hash2(__m256i i, __m256i j) const { return hash(_mm256_add_epi32(hash(i), j)); }
  REEFGEN_AVX2 static __m256i wrap(__m256i i, __m256i mask, __m256i shift) {
    return _mm256_and_si256(_mm256_add_epi32(_mm256_and_si256(i, mask), shift), _mm256_set1_epi32(255));
  }

  REEFGEN_AVX2 __m256 operator()(__m256 x, __m256 y) const {
    const __m256 fx = _mm256_floor_ps(x), fy = _mm256_floor_ps(y);
    const __m256i m255 = _mm256_set1_epi32(255), one = _mm256_set1_epi32(1);
    const __m256i X = _mm256_and_si256(_mm256_cvttps_epi32(fx), m255), Y = _mm256_and_si256(_mm256_cvttps_epi32(fy), m255);
    x = _mm256_sub_ps(x, fx);
    y = _mm256_sub_ps(y, fy);
    const __m256 u = fade8(x), v = fade8(y);
    const __m256i a = _mm256_add_epi32(hash(X), Y), b = _mm256_add_epi32(hash(_mm256_add_epi32(X, one)), Y);
    const __m256 x1 = _mm256_sub_ps(x, _mm256_set1_ps(1.f)), y1 = _mm256_sub_ps(y, _mm256_set1_ps(1.f));
    const __m256 n = lerp8(lerp8(grad8(hash(a), x, y), grad8(hash(b), x1, y), u),
                           lerp8(grad8(hash(_mm256_add_epi32(a, one)), x, y1), grad8(hash(_mm256_add_epi32(b, one)), x1, y1), u), v);
    return clamp8(n);
  }

  // perlin_periodic() for a period that is a power of two, where
  // ((i % period) + period) % period is i & (period − 1).
  REEFGEN_AVX2 __m256 periodic(__m256 x, __m256 y, int period, int salt) const {
    const __m256 fx = _mm256_floor_ps(x), fy = _mm256_floor_ps(y);
    const __m256i X0 = _mm256_cvttps_epi32(fx), Y0 = _mm256_cvttps_epi32(fy), one = _mm256_set1_epi32(1);
    const __m256i mask = _mm256_set1_epi32(period - 1), shift = _mm256_set1_epi32(37 * salt);
    const __m256i X = wrap(X0, mask, shift), X1 = wrap(_mm256_add_epi32(X0, one), mask, shift);
    const __m256i Y = wrap(Y0, mask, shift), Y1 = wrap(_mm256_add_epi32(Y0, one), mask, shift);
    x = _mm256_sub_ps(x, fx);
    y = _mm256_sub_ps(y, fy);
    const __m256 u = fade8(x), v = fade8(y);
    const __m256 x1 = _mm256_sub_ps(x, _mm256_set1_ps(1.f)), y1 = _mm256_sub_ps(y, _mm256_set1_ps(1.f));
    const __m256 n = lerp8(lerp8(grad8(hash2(X, Y), x, y), grad8(hash2(X1, Y), x1, y), u),
                           lerp8(grad8(hash2(X, Y1), x, y1), grad8(hash2(X1, Y1), x1, y1), u), v);
    return clamp8(n);
  }

  // std::clamp(n, −1, 1): n itself unless it is below −1 or above 1.
  REEFGEN_AVX2 static __m256 clamp8(__m256 n) {
    const __m256 lo = _mm256_set1_ps(-1.f), hi = _mm256_set1_ps(1.f);
    const __m256 c = _mm256_blendv_ps(n, lo, _mm256_cmp_ps(n, lo, _CMP_LT_OQ));
    return _mm256_blendv_ps(c, hi, _mm256_cmp_ps(hi, c, _CMP_LT_OQ));
  }
};

void fbm_row_scalar(const GradientNoise2& g, const int32_t*, const float* x, const float* y, int n, int octaves, float* out) {
  for (int i = 0; i < n; ++i) out[i] = g.fbm(x[i], y[i], octaves);
}

// fbm()'s loop on eight points: the octave offsets, amplitudes and their sum
// are the same scalars for every lane.
REEFGEN_AVX2 void fbm_row_avx2(const GradientNoise2& g, const int32_t* perm, const float* xs, const float* ys, int n,
                               int octaves, float* out) {
  const Perlin8 perlin{perm};
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    __m256 x = _mm256_loadu_ps(xs + i), y = _mm256_loadu_ps(ys + i), sum = _mm256_setzero_ps();
    float amp = 1, norm = 0;
    for (int o = 0; o < octaves; ++o) {
      const __m256 p = perlin(_mm256_add_ps(x, _mm256_set1_ps(17.31f * o)), _mm256_sub_ps(y, _mm256_set1_ps(9.73f * o)));
      sum = _mm256_add_ps(sum, _mm256_mul_ps(_mm256_set1_ps(amp), p));
      norm += amp;
      amp *= 0.5f;
      x = _mm256_mul_ps(x, _mm256_set1_ps(2.f));
      y = _mm256_mul_ps(y, _mm256_set1_ps(2.f));
    }
    _mm256_storeu_ps(out + i, _mm256_div_ps(sum, _mm256_set1_ps(norm)));
  }
  fbm_row_scalar(g, perm, xs + i, ys + i, n - i, octaves, out + i);
}

void periodic_row_scalar(const GradientNoise2& g, const int32_t*, const float* x, const float* y, int n, int period,
                         int salt, float* out) {
  for (int i = 0; i < n; ++i) out[i] = g.perlin_periodic(x[i], y[i], period, salt);
}

REEFGEN_AVX2 void periodic_row_avx2(const GradientNoise2& g, const int32_t* perm, const float* xs, const float* ys,
                                    int n, int period, int salt, float* out) {
  const Perlin8 perlin{perm};
  int i = 0;
  if ((period & (period - 1)) == 0)
    for (; i + 8 <= n; i += 8)
      _mm256_storeu_ps(out + i, perlin.periodic(_mm256_loadu_ps(xs + i), _mm256_loadu_ps(ys + i), period, salt));
  periodic_row_scalar(g, perm, xs + i, ys + i, n - i, period, salt, out + i);
}

GradientNoise2::FbmRowFn fbm_row_for_this_cpu() {
  return pick_path<GradientNoise2::FbmRowFn>(&fbm_row_scalar, &fbm_row_avx2, &fbm_row_avx2);
}

}  // namespace

void GradientNoise2::fbm_n(const float* x, const float* y, int n, int octaves, float* out) const {
  fbm_row_(*this, perm32_.data(), x, y, n, octaves, out);
}

void GradientNoise2::perlin_periodic_n(const float* x, const float* y, int n, int period, int salt, float* out) const {
  using Fn = void (*)(const GradientNoise2&, const int32_t*, const float*, const float*, int, int, int, float*);
  pick_path<Fn>(&periodic_row_scalar, &periodic_row_avx2, &periodic_row_avx2)(*this, perm32_.data(), x, y, n, period, salt, out);
}

NoiseTile::NoiseTile(int octaves) : t_(static_cast<size_t>(kSize) * kSize) {
  // Periodic Perlin: lattice indices wrap at the period (in cells) of each
  // octave, so the tile repeats seamlessly. Fixed seed: the tile is part of
  // the generator's definition, islands differ by where they sample it.
  // A row's octave at a time on the CPU's vector path (perlin_periodic_n),
  // summed per texel in fbm's order: the bits of the texel-by-texel sum.
  const GradientNoise2 g(0x5EEDu);
  std::vector<float> u(kSize), v(kSize), octave(kSize), sum(kSize);
  for (int y = 0; y < kSize; ++y) {
    std::fill(sum.begin(), sum.end(), 0.f);
    float amp = 1, norm = 0;
    int cell = kBaseCell;
    for (int o = 0; o < octaves; ++o, cell /= 2) {
      for (int x = 0; x < kSize; ++x) u[x] = float(x) / cell + 0.5f / cell, v[x] = float(y) / cell + 0.5f / cell;
      g.perlin_periodic_n(u.data(), v.data(), kSize, kSize / cell, o, octave.data());
      for (int x = 0; x < kSize; ++x) sum[x] += amp * octave[x];
      norm += amp;
      amp *= 0.5f;
    }
    for (int x = 0; x < kSize; ++x) t_[static_cast<size_t>(y) * kSize + x] = sum[x] / norm;
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
    const double s = smoothstep(f);
    sum += amp * (lat[i0] + s * (lat[i1] - lat[i0]));
    norm += amp;
    amp *= 0.5;
  }
  return sum / norm;
}

}  // namespace reefgen::terrain
