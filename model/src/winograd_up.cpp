#include "winograd_up.hpp"

#include "reefgen/vector_path.hpp"

#include <ATen/Parallel.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace reefgen::model {

namespace {

using dt = dnnl::memory::data_type;
using tag = dnnl::memory::format_tag;

constexpr int kPoints = 9;        // Winograd points of F(2×2, 2×2): a 3×3 tile
constexpr int64_t kTileGrain = 8;  // tiles per parallel task (fixed: results do not depend on it)
constexpr int64_t kSgemmCols = 64;  // output columns per sgemm task (measured: 64 beats 128 and 256 at 81 tiles)

// Parity py of the transposed 4×4 kernel: rows {3, 1} over input rows
// {m-1, m} (py = 0) or {2, 0} over {m, m+1} (py = 1).
int64_t kernel_index(int parity, int a) { return parity ? (a ? 0 : 2) : (a ? 1 : 3); }

// U[ξ = 3u+v][c][p·Cout + o] = Σ_ab G[u][a]·G[v][b]·w[c][o][ky(a)][kx(b)],
// G = [[1,0],[1,1],[0,1]]: the filter transform of F(2,2) on both axes.
torch::Tensor transformed_filters(const torch::Tensor& w_iohw) {
  const torch::Tensor w = w_iohw.to(torch::kFloat32).contiguous();
  const int64_t cin = w.size(0), cout = w.size(1);
  torch::Tensor u = torch::zeros({kPoints, cin, 4 * cout});  // {9, Cin, 4·Cout}
  static const float G[3][2] = {{1, 0}, {1, 1}, {0, 1}};
  for (int p = 0; p < 4; ++p) {
    const int py = p >> 1, px = p & 1;
    for (int uu = 0; uu < 3; ++uu)
      for (int vv = 0; vv < 3; ++vv) {
        torch::Tensor acc = torch::zeros({cin, cout});
        for (int a = 0; a < 2; ++a)
          for (int b = 0; b < 2; ++b) {
            const float g = G[uu][a] * G[vv][b];
            if (g != 0.f) acc += g * w.select(2, kernel_index(py, a)).select(2, kernel_index(px, b));
          }
        u[uu * 3 + vv].narrow(1, p * cout, cout).copy_(acc);
      }
  }
  return u;
}

// The transforms' inner loops, one path per vector width (common/
// vector_path.hpp, capped by REEFGEN_CPU_PATH): adds and subtracts only, so
// every path gives the same bits.

// (a - b, b, c - b): F(2,2)'s input transform along one axis.
REEFGEN_INLINE_BODY void input_1d_body(const float* a, const float* b, const float* c, float* o0, float* o1, float* o2,
                                  int64_t n) {
  for (int64_t i = 0; i < n; ++i) o0[i] = a[i] - b[i], o1[i] = b[i], o2[i] = c[i] - b[i];
}
REEFGEN_DISPATCHED(void, input_1d, (const float* a, const float* b, const float* c, float* o0, float* o1, float* o2, int64_t n), (a, b, c, o0, o1, o2, n))
REEFGEN_INLINE_BODY void add_rows_body(const float* a, const float* b, float* out, int64_t n) {
  for (int64_t i = 0; i < n; ++i) out[i] = a[i] + b[i];
}
REEFGEN_DISPATCHED(void, add_rows, (const float* a, const float* b, float* out, int64_t n), (a, b, out, n))
REEFGEN_INLINE_BODY void add_rows_bias_body(const float* a, const float* b, const float* bias, float* out, int64_t n) {
  for (int64_t i = 0; i < n; ++i) out[i] = (a[i] + b[i]) + bias[i];
}
REEFGEN_DISPATCHED(void, add_rows_bias, (const float* a, const float* b, const float* bias, float* out, int64_t n), (a, b, bias, out, n))

}  // namespace

WinogradGemm winograd_gemm() {
  if (const char* e = std::getenv("REEFGEN_WINOGRAD_GEMM")) {
    const std::string v = e;
    if (v == "matmul") return WinogradGemm::Matmul;
    if (v == "sgemm") return WinogradGemm::Sgemm;
    throw std::invalid_argument("REEFGEN_WINOGRAD_GEMM='" + v + "': use matmul or sgemm (or unset it)");
  }
  switch (dnnl::get_effective_cpu_isa()) {
    case dnnl::cpu_isa::avx512_core:
    case dnnl::cpu_isa::avx512_core_vnni:
    case dnnl::cpu_isa::avx512_core_bf16:
    case dnnl::cpu_isa::avx512_core_amx:
      return WinogradGemm::Matmul;
    default:
      return WinogradGemm::Sgemm;
  }
}

// The smallest side where the Winograd decoder beats oneDNN's direct kernels:
// 16 on the sgemm path (AVX2), 32 on AVX-512, where side 16 gains nothing
// (docs/BENCHMARKS.md, "Winograd decoder", has the figures per CPU class).
int64_t winograd_min_side(WinogradGemm gemm) { return gemm == WinogradGemm::Sgemm ? 16 : 32; }

ParityWinograd::ParityWinograd(const torch::Tensor& w, const torch::Tensor& b, int64_t N, int64_t s,
                               const dnnl::engine& eng, WinogradGemm gemm)
    : n_(N), s_(s), cin_(w.size(0)), cout_(w.size(1)), tiles_side_(s / 2 + 1), tiles_(N * (s / 2 + 1) * (s / 2 + 1)),
      gemm_kind_(gemm) {
  if (w.dim() != 4 || w.size(2) != 4 || w.size(3) != 4 || s < 2 || s % 2)
    throw std::invalid_argument("ParityWinograd: needs {Cin,Cout,4,4} weights and an even side");
  bias_ = b.defined() ? b.to(torch::kFloat32).contiguous() : torch::zeros({cout_});
  const dnnl::memory::dims src_d{kPoints, tiles_, cin_}, w_d{kPoints, cin_, 4 * cout_}, dst_d{kPoints, tiles_, 4 * cout_};
  const dnnl::memory::desc src_md(src_d, dt::f32, tag::abc), dst_md(dst_d, dt::f32, tag::abc);
  v_ = dnnl::memory(src_md, eng);
  m_ = dnnl::memory(dst_md, eng);
  const torch::Tensor u = transformed_filters(w);  // {9, Cin, 4·Cout}
  if (gemm == WinogradGemm::Sgemm) {
    // Stored transposed, {9, 4·Cout, Cin}: the AVX2 sgemm kernel is fast on
    // it whatever the buffer's alignment (it is not on {Cin, 4·Cout}).
    const torch::Tensor ut = u.transpose(1, 2).contiguous();
    u_ = dnnl::memory({{kPoints, 4 * cout_, cin_}, dt::f32, tag::abc}, eng);
    std::memcpy(u_.get_data_handle(), ut.data_ptr<float>(), size_t(ut.numel()) * sizeof(float));
    return;
  }
  dnnl::matmul::primitive_desc pd;
  try {
    const dnnl::memory::desc w_any(w_d, dt::f32, tag::any);
    pd = dnnl::matmul::primitive_desc(dnnl::matmul::desc(src_md, w_any, dst_md), eng);
  } catch (const dnnl::error& e) {
    throw std::runtime_error(std::string("oneDNN cannot build the Winograd decoder's matmul (") + e.what() + ")");
  }
  gemm_ = dnnl::matmul(pd);
  u_ = dnnl::memory(pd.weights_desc(), eng);
  dnnl::memory user({w_d, dt::f32, tag::abc}, eng, u.data_ptr());
  dnnl::stream strm(eng);
  dnnl::reorder(user, u_).execute(strm, user, u_);
  strm.wait();
}

void ParityWinograd::multiply(dnnl::stream& strm) {
  if (gemm_kind_ == WinogradGemm::Matmul) {
    gemm_.execute(strm, {{DNNL_ARG_SRC, v_}, {DNNL_ARG_WEIGHTS, u_}, {DNNL_ARG_DST, m_}});
    strm.wait();
    return;
  }
  const int64_t T = tiles_, C = cin_, Q = 4 * cout_, blocks = (Q + kSgemmCols - 1) / kSgemmCols;
  const float* V = static_cast<const float*>(v_.get_data_handle());
  const float* U = static_cast<const float*>(u_.get_data_handle());
  float* M = static_cast<float*>(m_.get_data_handle());
  // Tasks of fixed shape (a point, a block of columns), each one sgemm on its
  // thread (oneDNN runs one thread inside a parallel region): the bytes do
  // not depend on the thread count, which a threaded sgemm's do on AVX2.
  std::atomic<int> failed{0};
  at::parallel_for(0, kPoints * blocks, 1, [&](int64_t t0, int64_t t1) {
    for (int64_t t = t0; t < t1; ++t) {
      const int64_t k = t / blocks, q0 = (t % blocks) * kSgemmCols, nq = std::min(kSgemmCols, Q - q0);
      // Row-major M[k][:, q0 .. q0+nq) = V[k] {T, C} × (U[k] rows q0 .. q0+nq, stored {Q, C})ᵀ.
      const dnnl_status_t st = dnnl_sgemm('N', 'T', T, nq, C, 1.f, V + k * T * C, C, U + (k * Q + q0) * C, C, 0.f,
                                          M + k * T * Q + q0, Q);
      if (st != dnnl_success) failed = int(st);
    }
  });
  if (failed) throw std::runtime_error("oneDNN's sgemm failed in the Winograd decoder (status " + std::to_string(failed.load()) + ")");
}

void ParityWinograd::run(const float* src, float* const dst[4], dnnl::stream& strm) {
  const int64_t s = s_, C = cin_, OC = cout_, ts = tiles_side_, T = tiles_;
  float* V = static_cast<float*>(v_.get_data_handle());
  // Input transform: tile (n, ty, tx) reads x rows and columns 2t-1 .. 2t+1.
  const std::vector<float> zeros(size_t(C), 0.f);
  at::parallel_for(0, T, kTileGrain, [&](int64_t t0, int64_t t1) {
    std::vector<float> e(size_t(9 * C));
    for (int64_t t = t0; t < t1; ++t) {
      const int64_t n = t / (ts * ts), ty = (t / ts) % ts, tx = t % ts;
      const float* d[3][3];
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) {
          const int64_t r = 2 * ty - 1 + k, c = 2 * tx - 1 + l;
          d[k][l] = r >= 0 && r < s && c >= 0 && c < s ? src + ((n * s + r) * s + c) * C : zeros.data();
        }
      // Rows: e[u][l] = (d0 - d1, d1, d2 - d1)[u] at column l.
      for (int l = 0; l < 3; ++l) {
        float* e0 = &e[size_t((0 * 3 + l) * C)];
        float* e1 = &e[size_t((1 * 3 + l) * C)];
        float* e2 = &e[size_t((2 * 3 + l) * C)];
        input_1d(d[0][l], d[1][l], d[2][l], e0, e1, e2, C);
      }
      // Columns: V[3u+v] = (e0 - e1, e1, e2 - e1)[v] of row u.
      for (int uu = 0; uu < 3; ++uu) {
        const float *a = &e[size_t((uu * 3 + 0) * C)], *b = &e[size_t((uu * 3 + 1) * C)], *c = &e[size_t((uu * 3 + 2) * C)];
        float* v0 = V + ((uu * 3 + 0) * T + t) * C;
        float* v1 = V + ((uu * 3 + 1) * T + t) * C;
        float* v2 = V + ((uu * 3 + 2) * T + t) * C;
        input_1d(a, b, c, v0, v1, v2, C);
      }
    }
  });
  multiply(strm);
  // Output transform: Y = Aᵀ M A, A = [[1,0],[1,1],[0,1]]; parity p keeps
  // z(r, c) at output (r - py, c - px) inside the s×s plane.
  const float* M = static_cast<const float*>(m_.get_data_handle());
  const float* bias = bias_.data_ptr<float>();
  const int64_t Q = 4 * OC;
  at::parallel_for(0, T, kTileGrain, [&](int64_t t0, int64_t t1) {
    std::vector<float> f(size_t(6 * OC));
    for (int64_t t = t0; t < t1; ++t) {
      const int64_t n = t / (ts * ts), ty = (t / ts) % ts, tx = t % ts;
      for (int p = 0; p < 4; ++p) {
        const int py = p >> 1, px = p & 1;
        const float* m[9];
        for (int k = 0; k < 9; ++k) m[k] = M + (k * T + t) * Q + p * OC;
        // Rows: f[i][v] = m[i][v] + m[i+1][v].
        for (int i = 0; i < 2; ++i)
          for (int v = 0; v < 3; ++v) {
            add_rows(m[i * 3 + v], m[(i + 1) * 3 + v], &f[size_t((i * 3 + v) * OC)], OC);
          }
        for (int i = 0; i < 2; ++i) {
          const int64_t row = 2 * ty + i - py;
          if (row < 0 || row >= s) continue;
          for (int j = 0; j < 2; ++j) {
            const int64_t col = 2 * tx + j - px;
            if (col < 0 || col >= s) continue;
            add_rows_bias(&f[size_t((i * 3 + j) * OC)], &f[size_t((i * 3 + j + 1) * OC)], bias,
                          dst[p] + ((n * s + row) * s + col) * OC, OC);
          }
        }
      }
    }
  });
}

}  // namespace reefgen::model
