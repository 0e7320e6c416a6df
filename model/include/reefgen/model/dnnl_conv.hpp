#pragma once
// Differentiable convolutions on oneDNN for training.
//
// LibTorch 1.13 trains pix2pix's convolutions far below the CPU's speed: its
// transposed convolutions (forward and both backward passes) run im2col +
// GEMM, and its oneDNN path reorders every weight again on every call — the
// 512-channel layers near the bottleneck, where a step is bound by moving
// weights, run at 4–50 GFLOP/s. dnnl_conv2d computes the same maths with
// oneDNN's convolution / deconvolution primitives directly:
//   - forward, backward-data and backward-weights (+ bias) primitives, their
//     descriptors built once per shape;
//   - each weight reordered into the primitive's layout once per update: D's
//     three forwards and two backward passes of a pix2pix step share one
//     packed copy (keyed by the parameter and its version counter);
//   - the forward's packed input kept for the backward-weights pass;
//   - bf16 precision: inputs, weights and incoming gradients rounded to
//     bfloat16 inside the primitives (float32 accumulation); every tensor
//     LibTorch sees — outputs, gradients, the weights themselves — stays
//     float32, so the optimiser keeps float32 master weights.
// Same results as torch::conv2d / conv_transpose2d within 1e-4 in float32
// (tested, forward and all gradients). Results depend on the thread count
// (oneDNN splits its reductions by thread), as LibTorch's do.
#include <torch/torch.h>

namespace reefgen::model {

enum class ConvPrecision { Fp32, Bf16 };

struct ConvGeometry {
  int64_t stride = 1;       // both axes; [1, 4]
  int64_t padding = 0;      // zeros on every side; [0, kernel)
  bool transposed = false;  // ConvTranspose2d (weights {in,out,k,k}) instead of Conv2d ({out,in,k,k})
};

// x {N,Cin,H,W} float32; w {Cout,Cin,K,K} (or {Cin,Cout,K,K} transposed);
// b {Cout} or undefined -> {N,Cout,OH,OW} float32, differentiable in x, w, b.
torch::Tensor dnnl_conv2d(const torch::Tensor& x, const torch::Tensor& w, const torch::Tensor& b,
                          const ConvGeometry& geometry, ConvPrecision precision = ConvPrecision::Fp32);

// avx512_bf16 or AMX-bf16 (cpuid), unless REEFGEN_NO_BF16 hides them or
// DNNL_MAX_CPU_ISA caps oneDNN below them: where bf16 convolutions pay.
bool cpu_has_native_bf16();
bool cpu_has_amx_bf16();
// Whether oneDNN can run bf16 convolutions here at all (any AVX-512 CPU,
// emulated where it has no bf16 instructions); false under REEFGEN_NO_BF16.
bool bf16_convolution_available();
// Throws the one-line "oneDNN cannot build a bf16 convolution on this CPU
// (<cpu summary>): <fix>" where bf16_convolution_available() is false.
void require_bf16_convolution(const std::string& fix);

// Packed weight copies currently held (tests; the cache drops a copy when its
// parameter is freed).
size_t dnnl_weight_cache_size();

}  // namespace reefgen::model
