// OutlineTable::xt_row: x̃ for a row of points on the CPU's vector path
// (reefgen/vector_path.hpp). The same operations as OutlineTable::xt in the
// same order, with its branches turned into selects, so every path gives
// xt()'s bits exactly.
#include <algorithm>
#include <cmath>

#include "reefgen/procgen/generator.hpp"
#include "reefgen/vector_path.hpp"

namespace reefgen::procgen {

namespace {

// fast_atan2 of generator.cpp, branch-free, the same bits.
REEFGEN_INLINE_BODY float atan2_selects(float y, float x) {
  const float ax = std::fabs(x), ay = std::fabs(y);
  const float mx = std::max(ax, ay), mn = std::min(ax, ay);
  // At the origin (mx = 0, so mn = 0) a = 0 and every step below keeps +0,
  // fast_atan2's early return; dividing by 1 there keeps the loop branch-free.
  const float a = mn / (mx == 0.f ? 1.f : mx), s = a * a;
  float r = ((((((-0.01172120f * s + 0.05265332f) * s - 0.11643287f) * s + 0.19354346f) * s - 0.33262347f) * s) +
             0.99997726f) * a;
  r = ay > ax ? 1.57079637f - r : r;
  r = x < 0.f ? 3.14159274f - r : r;
  return y < 0.f ? -r : r;
}

// table: kAngles + 1 rows of the 5 radii R_1..R_5.
REEFGEN_INLINE_BODY void xt_body(const float* __restrict table, float outer2, const float* __restrict xs,
                                 const float* __restrict ys, int n, float* __restrict out) {
  constexpr int kA = OutlineTable::kAngles;
  const float to_turn = static_cast<float>(kA / (2.0 * M_PI));
  for (int p = 0; p < n; ++p) {
    const float x = xs[p], y = ys[p];
    const float r2 = x * x + y * y;
    const float r = std::sqrt(r2);
    float tt = atan2_selects(y, x) * to_turn;
    tt = tt < 0.f ? tt + kA : tt;
    const int i = std::min(static_cast<int>(tt), kA - 1);
    const float f = tt - i;
    // Rows i and i + 1 of the table, indexed from `table` (gathers).
    const int row = 5 * i;
    float R[5];
    for (int j = 0; j < 5; ++j) R[j] = table[row + j] + f * (table[row + 5 + j] - table[row + j]);
    // The first band j with r < R_j, as xt()'s early return finds it.
    float x_t = 5.f;
    for (int j = 4; j >= 0; --j) {
      const float lo = j == 0 ? 0.f : R[j - 1];
      x_t = r < R[j] ? j + (r - lo) / (R[j] - lo) : x_t;
    }
    out[p] = r2 >= outer2 ? 5.f : x_t;
  }
}

void xt_sse2(const float* t, float o, const float* x, const float* y, int n, float* out) { xt_body(t, o, x, y, n, out); }
REEFGEN_AVX2 void xt_avx2(const float* t, float o, const float* x, const float* y, int n, float* out) {
  xt_body(t, o, x, y, n, out);
}
REEFGEN_AVX512 void xt_avx512(const float* t, float o, const float* x, const float* y, int n, float* out) {
  xt_body(t, o, x, y, n, out);
}

}  // namespace

void OutlineTable::xt_row(const float* x, const float* y, int n, float* out) const {
  using Fn = void (*)(const float*, float, const float*, const float*, int, float*);
  pick_path<Fn>(&xt_sse2, &xt_avx2, &xt_avx512)(r_.front().data(), outer2_, x, y, n, out);
}

}  // namespace reefgen::procgen
