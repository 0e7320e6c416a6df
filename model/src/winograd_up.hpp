#pragma once
// pix2pix's 4×4 stride-2 transposed convolution, float32, with Winograd's
// minimal filtering F(2×2, 2×2): 9 multiplications per 2×2 output tile and
// input channel instead of 16 (docs/BENCHMARKS.md, "Winograd decoder").
//
// The engine computes the transposed convolution as four 2×2 convolutions,
// one per output parity (py, px), each over the same input x padded by one
// pixel: parity (py, px) at output (i, j) is z_p(i+py, j+px) with
//   z_p(r, c) = Σ_{a,b∈{0,1}} x(r+a-1, c+b-1) · w_p(a, b).
// All four parities share the input, so the input transform is done once for
// 2×2 tiles of z on a (s+1)² grid, and the four parities' filters are the
// columns of one GEMM per Winograd point: 9 GEMMs of
//   V[ξ] {tiles, Cin} × U[ξ] {Cin, 4·Cout} -> M[ξ] {tiles, 4·Cout}
// (weights transformed once; who multiplies: WinogradGemm below). The transforms (Lavin & Gray,
// "Fast Algorithms for Convolutional Neural Networks", CVPR 2016) for F(2,2):
//   m1 = (d0 - d1)·g0,  m2 = d1·(g0 + g1),  m3 = (d2 - d1)·g1,
//   y0 = m1 + m2,       y1 = m2 + m3,
// applied along rows then columns. They only add and subtract, so the result
// differs from the direct convolution by float rounding alone (≤ 1e-5
// relative, tested). Every value is computed by one thread in a fixed order:
// the same bytes whatever the thread count.
#include <cstdint>
#include <memory>

#include <oneapi/dnnl/dnnl.hpp>
#include <torch/torch.h>

namespace reefgen::model {

// Who multiplies the 9 GEMMs. oneDNN's matmul primitive runs brgemm kernels
// from AVX-512 up; below that it falls back to a generic GEMM that splits the
// batch of 9 over the threads, 1.4-1.9× slower at 289 or 81 tiles than nine
// dnnl_sgemm calls with U stored transposed (docs/BENCHMARKS.md, "Winograd
// decoder"). The choice is fixed by the CPU, so a machine always gives the
// same bytes.
enum class WinogradGemm { Matmul, Sgemm };
// This CPU's backend: Matmul where oneDNN has AVX-512 (after
// DNNL_MAX_CPU_ISA), else Sgemm. REEFGEN_WINOGRAD_GEMM=matmul|sgemm forces
// one (tests cover both on any CPU); another value throws.
WinogradGemm winograd_gemm();
// Smallest decoder input side run as Winograd with that backend: below it the
// tiles are too few for the GEMMs to beat oneDNN's direct kernels (measured).
int64_t winograd_min_side(WinogradGemm gemm);

class ParityWinograd {
 public:
  // w {Cin, Cout, 4, 4} (ConvTranspose2d's layout), b {Cout} or undefined;
  // N images of side s (even) in, four {N, s, s, Cout} parity planes out.
  ParityWinograd(const torch::Tensor& w, const torch::Tensor& b, int64_t N, int64_t s, const dnnl::engine& eng,
                 WinogradGemm gemm);
  // src: nhwc float32 {N, s, s, Cin}; dst[2·py + px]: nhwc float32 {N, s, s, Cout}.
  void run(const float* src, float* const dst[4], dnnl::stream& strm);

 private:
  // The 9 GEMMs M[ξ] = V[ξ] U[ξ] on the chosen backend.
  void multiply(dnnl::stream& strm);

  int64_t n_, s_, cin_, cout_, tiles_side_, tiles_;
  WinogradGemm gemm_kind_;
  torch::Tensor bias_;            // {Cout} float32 (zeros when the layer has none)
  dnnl::memory v_, u_, m_;        // V {9, tiles, Cin}, U packed (plain {9, 4·Cout, Cin} for sgemm), M {9, tiles, 4·Cout}
  dnnl::matmul gemm_;
};

}  // namespace reefgen::model
