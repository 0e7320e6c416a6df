#pragma once
// How far bf16 inference may lie from float32, derived from bf16's mantissa
// rather than measured on one CPU (oneDNN's kernels differ by class: AVX-512
// bf16 dot products, AMX tiles with another accumulation order). Shared by
// the engine tests (test_infer.cpp, test_fast_unet.cpp).
#include <cmath>

#include "reefgen/model/networks.hpp"

namespace reefgen::test {

// The bf16 format has 8 significant bits: a value in [1/2, 1) is rounded
// within ±2^-9 (its spacing is 2^-8), uniformly spread, a mean |error| of
// 2^-10. Normalised layers keep activations of order one, so one rounding
// moves the network's output t = tanh(·) by about that, and heights
// lo + (t + 1)/2·(hi − lo) by (hi − lo)/2 · 2^-10 (0.32 m at 660 m).
inline double bf16_full_scale_rounding_m(double lo_m, double hi_m) {
  return 0.5 * (hi_m - lo_m) * std::ldexp(1.0, -10);
}

// Convolutions of a generator (4-d weights): each rounds its operands to bf16.
inline int convolution_count(model::UNetGenerator& g) {
  int n = 0;
  for (const auto& p : g->parameters()) n += p.dim() == 4;
  return n;
}

// The mean |bf16 − fp32| height bound: each of the L convolutions rounds its
// operands once and the output once more; independent roundings add in
// quadrature, √(L + 1) of them.
inline double bf16_mean_bound_m(model::UNetGenerator& g, double lo_m, double hi_m) {
  return std::sqrt(double(convolution_count(g) + 1)) * bf16_full_scale_rounding_m(lo_m, hi_m);
}

}  // namespace reefgen::test
