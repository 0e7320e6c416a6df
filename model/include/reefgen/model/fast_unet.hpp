#pragma once
// UNetGenerator inference on oneDNN directly.
//
// LibTorch 1.13 runs pix2pix's G far below what the CPU can do: every call of
// its oneDNN convolution reorders the weights again (the 512-channel layers
// near the bottleneck run at 3–40 GFLOP/s), transposed convolutions go through
// im2col + GEMM with zero-filled buffers, and each cat / norm / activation is
// its own pass. This engine compiles one generator, for one batch size and
// side, into oneDNN convolutions with weights packed once, on channels-last
// (nhwc) buffers allocated once:
//   - a 4×4 stride-2 transposed convolution is computed exactly as four 2×2
//     convolutions, one per output parity (no zero taps, no col2im); in
//     float32 the larger levels run them as Winograd F(2×2, 2×2) GEMMs;
//   - the decoder's normalisation writes its output, activated and interleaved,
//     straight into the second half of the next level's concatenation buffer;
//     the encoder fills the first half in the same pass that activates its own
//     output (relu(leaky(d)) = relu(d)): no cat is ever materialised;
//   - normalisation statistics are summed in double over fixed row chunks, so
//     the result is the same bytes whatever the thread count;
//   - the output layer (1 channel, where oneDNN's blocking wastes 15/16 of its
//     work) is a direct dot-product kernel fused with tanh.
// bf16 precision keeps activations and weights in bfloat16 (float32
// accumulation, statistics and output layer): 2× on CPUs with avx512_bf16
// or AMX. Equal to UNetGenerator::forward within 1e-4 in float32 (tested).
#include <memory>
#include <string>

#include <torch/torch.h>

#include "reefgen/model/networks.hpp"

namespace reefgen::model {

enum class FastPrecision { Fp32, Bf16 };

struct FastUNetOptions {
  int batch = 1;       // images per forward; [1, 64]
  int size_px = 256;   // input side; a multiple of 2^depth; [32, 4096]
  FastPrecision precision = FastPrecision::Fp32;
  // float32 transposed decoder levels of side ≥ 16 (below AVX-512) or ≥ 32
  // through Winograd's F(2×2, 2×2) (winograd_up.hpp): 9/16 of the
  // multiplications, same result within float rounding. false: oneDNN's
  // direct convolutions (reference).
  bool winograd = true;
};

// Why this generator cannot run on the engine in its current mode ("" if it
// can): dropout switched on (stochastic inference) is the one case.
std::string fast_unet_unsupported(UNetGeneratorImpl& g);

// Who runs the Winograd decoder's GEMMs here: "matmul" (oneDNN's primitive,
// AVX-512) or "sgemm" (below it); REEFGEN_WINOGRAD_GEMM forces one.
std::string winograd_gemm_name();

class FastUNet {
 public:
  // A snapshot of g's weights and mode: train mode = BatchNorm with batch
  // statistics (pix2pix's test-time mode), eval mode = running statistics.
  // Throws std::runtime_error when oneDNN cannot build a layer (bf16 on a CPU
  // without AVX-512, say).
  FastUNet(UNetGeneratorImpl& g, const FastUNetOptions& options);
  ~FastUNet();
  FastUNet(const FastUNet&) = delete;
  FastUNet& operator=(const FastUNet&) = delete;

  // {batch,in,S,S} float32 in [-1,1] -> {batch,out,S,S} float32 in (-1,1).
  torch::Tensor forward(const torch::Tensor& x);
  const FastUNetOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace reefgen::model
