#include "steepest.hpp"

#include "reefgen/terrain/flow.hpp"
#include "reefgen/vector_path.hpp"

namespace reefgen::terrain {

namespace {

// One neighbour k: its slope² weight (0 unless lower and open) into w and
// sum, and the D8 choice. Branch-free, so the loop over x vectorises; the
// selects keep the scalar loop's order of updates, so every path gives the
// same bits.
REEFGEN_INLINE_BODY void visit(float z, float zn, uint8_t rn, int k, float inv, float& w, float& best_s,
                               int& best_k, float& sum) {
  const float sl = (z - zn) * inv;
  const bool open = rn != kIgnore;
  w = (open & (sl > 0.f)) ? sl * sl : 0.f;
  sum += w;
  const bool steeper = open & (sl > best_s);
  best_s = steeper ? sl : best_s;
  best_k = steeper ? k : best_k;
}

template <bool kDraw>
REEFGEN_INLINE_BODY void steepest_body(const float* __restrict z, const uint8_t* __restrict role, int W,
                                       const float inv[8], const float* __restrict draw,
                                       int8_t* __restrict receiver_k) {
  // Rows above (y − 1) and below (y + 1); neighbours in the kDx/kDy order of
  // neighbours.hpp: 4 axial, then 4 diagonal.
  const float *zu = z - W, *zd = z + W;
  const uint8_t *ru = role - W, *rd = role + W;
  for (int x = 1; x < W - 1; ++x) {
    const float c = z[x];
    float best_s = 0.f, sum = 0.f, w[8];
    int k_best = -1;
    visit(c, z[x + 1], role[x + 1], 0, inv[0], w[0], best_s, k_best, sum);
    visit(c, z[x - 1], role[x - 1], 1, inv[1], w[1], best_s, k_best, sum);
    visit(c, zd[x], rd[x], 2, inv[2], w[2], best_s, k_best, sum);
    visit(c, zu[x], ru[x], 3, inv[3], w[3], best_s, k_best, sum);
    visit(c, zd[x + 1], rd[x + 1], 4, inv[4], w[4], best_s, k_best, sum);
    visit(c, zu[x + 1], ru[x + 1], 5, inv[5], w[5], best_s, k_best, sum);
    visit(c, zd[x - 1], rd[x - 1], 6, inv[6], w[6], best_s, k_best, sum);
    visit(c, zu[x - 1], ru[x - 1], 7, inv[7], w[7], best_s, k_best, sum);
    if constexpr (kDraw) {
      // The scalar draw takes the first positive weight whose running sum
      // passes u, else the last positive one; adding a zero weight changes
      // no bit of the running sum.
      const float u = draw[x] * sum;
      float run[8];
      run[0] = w[0];
      for (int k = 1; k < 8; ++k) run[k] = run[k - 1] + w[k];
      int last = -1, first = -1;
      for (int k = 0; k < 8; ++k) last = w[k] > 0.f ? k : last;
      for (int k = 7; k >= 0; --k) first = (u < run[k]) & (w[k] > 0.f) ? k : first;
      const int k_draw = first >= 0 ? first : last;
      k_best = sum > 0.f ? k_draw : k_best;
    }
    receiver_k[x] = static_cast<int8_t>(k_best);
  }
}

REEFGEN_INLINE_BODY void steepest_any(const float* z, const uint8_t* role, int W, const float inv[8],
                                      const float* draw, int8_t* receiver_k) {
  if (draw) steepest_body<true>(z, role, W, inv, draw, receiver_k);
  else steepest_body<false>(z, role, W, inv, draw, receiver_k);
}

void steepest_sse2(const float* z, const uint8_t* role, int W, const float inv[8], const float* draw, int8_t* k) {
  steepest_any(z, role, W, inv, draw, k);
}
REEFGEN_AVX2 void steepest_avx2(const float* z, const uint8_t* role, int W, const float inv[8], const float* draw,
                                int8_t* k) {
  steepest_any(z, role, W, inv, draw, k);
}
REEFGEN_AVX512 void steepest_avx512(const float* z, const uint8_t* role, int W, const float inv[8],
                                    const float* draw, int8_t* k) {
  steepest_any(z, role, W, inv, draw, k);
}

}  // namespace

SteepestRowFn steepest_row() { return pick_path(&steepest_sse2, &steepest_avx2, &steepest_avx512); }

}  // namespace reefgen::terrain
