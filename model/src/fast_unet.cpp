#include "reefgen/model/fast_unet.hpp"

#include "reefgen/vector_path.hpp"

#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include <oneapi/dnnl/dnnl.hpp>
#include "reefgen/model/dnnl_conv.hpp"
#include "winograd_up.hpp"

namespace reefgen::model {
namespace {

using dt = dnnl::memory::data_type;
using tag = dnnl::memory::format_tag;
using bf16_t = uint16_t;  // oneDNN's bfloat16: the high half of a float32

constexpr double kEps = 1e-5;      // BatchNorm2d / InstanceNorm2d default
constexpr float kLeaky = 0.2f;     // pix2pix's LeakyReLU slope
constexpr int64_t kRowGrain = 4;   // rows per parallel task (fixed: results do not depend on it)

// Hot loops below are compiled for AVX-512, AVX2 and baseline x86-64 and the
// path this process runs on is picked once (common/vector_path.hpp: the CPU's
// features, capped by REEFGEN_CPU_PATH; the build itself has no -march flag).

inline bf16_t to_bf16(float f) {  // round to nearest even, NaN kept NaN
  uint32_t u;
  std::memcpy(&u, &f, 4);
  if ((u & 0x7fffffffu) > 0x7f800000u) return bf16_t((u >> 16) | 0x40u);
  u += 0x7fffu + ((u >> 16) & 1u);
  return bf16_t(u >> 16);
}
inline float from_bf16(bf16_t h) {
  const uint32_t u = uint32_t(h) << 16;
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

enum Act { kNone = 0, kRelu = 1, kLeakyRelu = 2 };

// y[p*C + c] = act(x[p*C + c] * scale[c] + shift[c]) over npix pixels.
REEFGEN_INLINE_BODY void affine_act_row_body(const float* x, float* y, int64_t npix, int64_t C, const float* scale,
                                   const float* shift, int act) {
  for (int64_t p = 0; p < npix; ++p) {
    const float* xp = x + p * C;
    float* yp = y + p * C;
    for (int64_t c = 0; c < C; ++c) {
      float v = xp[c] * scale[c] + shift[c];
      if (act == kRelu) v = v > 0.f ? v : 0.f;
      else if (act == kLeakyRelu) v = v > 0.f ? v : v * kLeaky;
      yp[c] = v;
    }
  }
}
REEFGEN_DISPATCHED(void, affine_act_row, (const float* x, float* y, int64_t npix, int64_t C, const float* scale, const float* shift, int act), (x, y, npix, C, scale, shift, act))

// Store npix pixels of C channels at dst + p*stride (float32 or bf16), relu'd if asked.
REEFGEN_INLINE_BODY void store_row_f32_body(const float* y, int64_t npix, int64_t C, float* dst, int64_t stride, bool relu) {
  for (int64_t p = 0; p < npix; ++p)
    for (int64_t c = 0; c < C; ++c) {
      const float v = y[p * C + c];
      dst[p * stride + c] = relu ? (v > 0.f ? v : 0.f) : v;
    }
}
REEFGEN_DISPATCHED(void, store_row_f32, (const float* y, int64_t npix, int64_t C, float* dst, int64_t stride, bool relu), (y, npix, C, dst, stride, relu))
REEFGEN_INLINE_BODY void store_row_bf16_body(const float* y, int64_t npix, int64_t C, bf16_t* dst, int64_t stride, bool relu) {
  for (int64_t p = 0; p < npix; ++p)
    for (int64_t c = 0; c < C; ++c) {
      const float v = y[p * C + c];
      dst[p * stride + c] = to_bf16(relu ? (v > 0.f ? v : 0.f) : v);
    }
}
REEFGEN_DISPATCHED(void, store_row_bf16, (const float* y, int64_t npix, int64_t C, bf16_t* dst, int64_t stride, bool relu), (y, npix, C, dst, stride, relu))

// Per-channel sum and sum of squares of one row, in double.
REEFGEN_INLINE_BODY void sums_row_body(const float* x, int64_t npix, int64_t C, double* sum, double* sq) {
  for (int64_t c = 0; c < C; ++c) sum[c] = sq[c] = 0.0;
  for (int64_t p = 0; p < npix; ++p)
    for (int64_t c = 0; c < C; ++c) {
      const double v = x[p * C + c];
      sum[c] += v;
      sq[c] += v * v;
    }
}
REEFGEN_DISPATCHED(void, sums_row, (const float* x, int64_t npix, int64_t C, double* sum, double* sq), (x, npix, C, sum, sq))

// The output layer's taps of npix pixels: out[p·TT + t] = Σ_c src[p·C + c] ·
// wt[c·TTp + t], each summed over c in order in one float, so every vector
// width and every grouping of pixels gives the same bits. wt is {C, TTp}
// (TTp a multiple of kTapLanes, zero-padded columns). Pixels go kTapPixels at
// a time against one row of 16 weights: a broadcast and a multiply-add per
// pixel, the accumulators held in registers (12 AVX2 registers).
constexpr int kTapLanes = 16;
constexpr int kTapPixels = 6;
// Eight lanes: one AVX2 register (the widest type every clone handles well).
typedef float Lanes8 __attribute__((vector_size(8 * sizeof(float))));
REEFGEN_INLINE_BODY void taps_rows_body(const float* src, int64_t npix, int64_t C, const float* wt, int64_t TT, int64_t TTp,
                              float* out) {
  for (int64_t p0 = 0; p0 < npix; p0 += kTapPixels) {
    const int64_t np = std::min<int64_t>(kTapPixels, npix - p0);
    // Past the last pixel, repeat it (results not stored): no branch in the loop.
    const float* row[kTapPixels];
    for (int q = 0; q < kTapPixels; ++q) row[q] = src + (p0 + std::min<int64_t>(q, np - 1)) * C;
    for (int64_t t0 = 0; t0 < TTp; t0 += kTapLanes) {
      Lanes8 lo[kTapPixels] = {}, hi[kTapPixels] = {};
      for (int64_t c = 0; c < C; ++c) {
        Lanes8 wlo, whi;
        std::memcpy(&wlo, wt + c * TTp + t0, sizeof wlo);
        std::memcpy(&whi, wt + c * TTp + t0 + 8, sizeof whi);
        for (int q = 0; q < kTapPixels; ++q) {
          const float x = row[q][c];
          lo[q] += x * wlo;
          hi[q] += x * whi;
        }
      }
      const int64_t nt = std::min<int64_t>(kTapLanes, TT - t0);
      for (int64_t q = 0; q < np; ++q)
        for (int64_t t = 0; t < nt; ++t) out[(p0 + q) * TT + t0 + t] = t < 8 ? lo[q][t] : hi[q][t - 8];
    }
  }
}
REEFGEN_DISPATCHED(void, taps_rows, (const float* src, int64_t npix, int64_t C, const float* wt, int64_t TT, int64_t TTp, float* out), (src, npix, C, wt, TT, TTp, out))

// Bilinear (align_corners=false) or nearest ×2 of one output row, nhwc, as
// PyTorch computes it: ((x00 w0x + x01 w1x) w0y + (x10 w0x + x11 w1x) w1y).
REEFGEN_INLINE_BODY void upsample_row_f32_body(const float* r0, const float* r1, float wy0, float wy1, int64_t side_in,
                                     int64_t C, float* out, bool bilinear) {
  for (int64_t ox = 0; ox < 2 * side_in; ++ox) {
    float* o = out + ox * C;
    if (!bilinear) {
      std::memcpy(o, r0 + (ox >> 1) * C, size_t(C) * 4);
      continue;
    }
    const float t = std::max(0.f, (ox + 0.5f) * 0.5f - 0.5f);
    const int64_t j0 = int64_t(t), j1 = std::min(j0 + 1, side_in - 1);
    const float wx1 = t - float(j0), wx0 = 1.f - wx1;
    const float *a = r0 + j0 * C, *b = r0 + j1 * C, *c = r1 + j0 * C, *d = r1 + j1 * C;
    for (int64_t k = 0; k < C; ++k) o[k] = (a[k] * wx0 + b[k] * wx1) * wy0 + (c[k] * wx0 + d[k] * wx1) * wy1;
  }
}
REEFGEN_DISPATCHED(void, upsample_row_f32, (const float* r0, const float* r1, float wy0, float wy1, int64_t side_in, int64_t C, float* out, bool bilinear), (r0, r1, wy0, wy1, side_in, C, out, bilinear))

REEFGEN_INLINE_BODY void bf16_to_f32_body(const bf16_t* a, float* b, int64_t n) {
  for (int64_t i = 0; i < n; ++i) b[i] = from_bf16(a[i]);
}
REEFGEN_DISPATCHED(void, bf16_to_f32, (const bf16_t* a, float* b, int64_t n), (a, b, n))
REEFGEN_INLINE_BODY void f32_to_bf16_body(const float* a, bf16_t* b, int64_t n) {
  for (int64_t i = 0; i < n; ++i) b[i] = to_bf16(a[i]);
}
REEFGEN_DISPATCHED(void, f32_to_bf16, (const float* a, bf16_t* b, int64_t n), (a, b, n))

}  // namespace

// The engine's parts, held by FastUNet::Impl: a named namespace, because a
// unity build (CMakeLists.txt) compiles this file inside another and a
// member of an anonymous type would then have no linkage.
namespace fast_unet_parts {

struct NormState {
  Norm kind = Norm::None;
  std::vector<double> gamma, beta, running_mean, running_var;  // BatchNorm only
};

// One convolution on oneDNN: nhwc src (float32 or bf16) -> nhwc float32 dst,
// weights packed once in oneDNN's preferred layout.
struct OneDnnConv {
  dnnl::convolution_forward prim;
  dnnl::memory weights, bias;
  bool has_bias = false;
  void run(dnnl::stream& s, dnnl::memory& src, dnnl::memory& dst) {
    std::unordered_map<int, dnnl::memory> args{{DNNL_ARG_SRC, src}, {DNNL_ARG_WEIGHTS, weights}, {DNNL_ARG_DST, dst}};
    if (has_bias) args[DNNL_ARG_BIAS] = bias;
    prim.execute(s, args);
  }
};

}  // namespace fast_unet_parts
using fast_unet_parts::OneDnnConv;
using fast_unet_parts::NormState;

namespace {

dnnl::memory::desc nhwc(int64_t n, int64_t c, int64_t side, dt t) {
  return dnnl::memory::desc({n, c, side, side}, t, tag::nhwc);
}

}  // namespace

struct FastUNet::Impl {
  FastUNetOptions o;
  UNetOptions u;
  bool batch_stats = true;
  dt ct = dt::f32;  // compute type of activations and weights
  dnnl::engine eng{dnnl::engine::kind::cpu, 0};
  dnnl::stream strm{eng};

  int64_t side(int k) const { return int64_t(o.size_px) >> (k + 1); }  // encoder output side of level k
  int64_t ch(int k) const { return int64_t(u.ngf) * std::min(1 << std::min(k, 3), 8); }

  // Buffers (nhwc). dconv[k]: encoder conv output (f32); act[k]: leaky(norm)
  // input of encoder k+1; cat[k]: [relu(act[k]) | relu(norm(up_{k+1}))];
  // inner: relu of the innermost output; upout[k]: the up-convolution's f32
  // output (four parity planes or one); ups[k]: resize input of level k.
  dnnl::memory x_in;
  std::vector<dnnl::memory> dconv, act, cat, ups;
  std::vector<std::vector<dnnl::memory>> upout;
  dnnl::memory inner;
  std::vector<OneDnnConv> down, up_convs_flat;
  std::vector<std::vector<OneDnnConv*>> up;  // per level: 4 parity convs or 1 resize conv (k >= 1)
  std::vector<std::unique_ptr<ParityWinograd>> wino;  // per level: the parity convs as Winograd GEMMs, or null
  std::vector<NormState> down_norm, up_norm;
  torch::Tensor out_wt, out_b;  // output layer: {C_in, out·kh·kw padded to kTapLanes} float32, {out}

  void* ptr(dnnl::memory& m) { return m.get_data_handle(); }

  OneDnnConv make_conv(const torch::Tensor& w_oihw, const torch::Tensor& b, int64_t side_in, dt src_t,
                 int64_t stride, dnnl::memory::dims pad_l, dnnl::memory::dims pad_r) {
    const torch::Tensor w = w_oihw.to(torch::kFloat32).contiguous();
    const int64_t oc = w.size(0), ic = w.size(1), kh = w.size(2), kw = w.size(3);
    const int64_t side_out = (side_in + pad_l[0] + pad_r[0] - kh) / stride + 1;
    dnnl::memory::desc wd({oc, ic, kh, kw}, src_t, tag::any), bd({oc}, dt::f32, tag::x);
    OneDnnConv c;
    c.has_bias = b.defined();
    dnnl::convolution_forward::primitive_desc pd;
    try {
      auto d = c.has_bias ? dnnl::convolution_forward::desc(dnnl::prop_kind::forward_inference,
                                                            dnnl::algorithm::convolution_direct,
                                                            nhwc(o.batch, ic, side_in, src_t), wd, bd,
                                                            nhwc(o.batch, oc, side_out, dt::f32), {stride, stride},
                                                            pad_l, pad_r)
                          : dnnl::convolution_forward::desc(dnnl::prop_kind::forward_inference,
                                                            dnnl::algorithm::convolution_direct,
                                                            nhwc(o.batch, ic, side_in, src_t), wd,
                                                            nhwc(o.batch, oc, side_out, dt::f32), {stride, stride},
                                                            pad_l, pad_r);
      pd = dnnl::convolution_forward::primitive_desc(d, eng);
    } catch (const dnnl::error& e) {
      throw std::runtime_error(std::string("oneDNN cannot build a ") + (src_t == dt::bf16 ? "bf16" : "float32") +
                               " convolution on this CPU (" + e.what() + "): use --precision fp32 or --engine torch");
    }
    c.prim = dnnl::convolution_forward(pd);
    dnnl::memory user({{oc, ic, kh, kw}, dt::f32, tag::oihw}, eng, w.data_ptr());
    c.weights = dnnl::memory(pd.weights_desc(), eng);
    dnnl::reorder(user, c.weights).execute(strm, user, c.weights);
    if (c.has_bias) {
      c.bias = dnnl::memory(bd, eng);
      const torch::Tensor bf = b.to(torch::kFloat32).contiguous();
      std::memcpy(c.bias.get_data_handle(), bf.data_ptr<float>(), size_t(oc) * 4);
    }
    strm.wait();
    return c;
  }

  // scale/shift {N or 1, C} for a norm over the given f32 planes (nhwc, each
  // N×side×side×C): statistics per image (instance), over the batch
  // (BatchNorm, batch statistics) or from the running averages.
  void norm_coeffs(const NormState& nm, const std::vector<float*>& planes, int64_t side_, int64_t C,
                   std::vector<float>& scale, std::vector<float>& shift, bool& per_image) {
    const int64_t N = o.batch;
    per_image = nm.kind == Norm::Instance;
    const int64_t groups = per_image ? N : 1;
    scale.assign(size_t(groups * C), 1.f);
    shift.assign(size_t(groups * C), 0.f);
    if (nm.kind == Norm::None) return;
    if (nm.kind == Norm::Batch && !batch_stats) {
      for (size_t c = 0; c < size_t(C); ++c) {
        const double s = nm.gamma[c] / std::sqrt(nm.running_var[c] + kEps);
        scale[c] = float(s);
        shift[c] = float(nm.beta[c] - nm.running_mean[c] * s);
      }
      return;
    }
    // Partial sums per row (image n, plane p, row i), then a fixed-order total.
    const int64_t P = int64_t(planes.size()), rows = N * P * side_;
    std::vector<double> sum(size_t(rows * C)), sq(size_t(rows * C));
    at::parallel_for(0, rows, kRowGrain, [&](int64_t b0, int64_t b1) {
      for (int64_t r = b0; r < b1; ++r) {
        const int64_t n = r / (P * side_), p = (r / side_) % P, i = r % side_;
        sums_row(planes[size_t(p)] + ((n * side_ + i) * side_) * C, side_, C, &sum[size_t(r * C)],
                 &sq[size_t(r * C)]);
      }
    });
    const double count = double(P * side_ * side_ * (per_image ? 1 : N));
    for (int64_t g = 0; g < groups; ++g) {
      for (int64_t c = 0; c < C; ++c) {
        double s = 0, q = 0;
        for (int64_t n = 0; n < N; ++n) {
          if (per_image && n != g) continue;
          for (int64_t r = n * P * side_; r < (n + 1) * P * side_; ++r) {
            s += sum[size_t(r * C + c)];
            q += sq[size_t(r * C + c)];
          }
        }
        const double mean = s / count, var = std::max(0.0, q / count - mean * mean);  // biased, as the norm uses
        double sc = 1.0 / std::sqrt(var + kEps), sh = -mean * sc;
        if (nm.kind == Norm::Batch) {
          sc *= nm.gamma[size_t(c)];
          sh = nm.beta[size_t(c)] - mean * sc;
        }
        scale[size_t(g * C + c)] = float(sc);
        shift[size_t(g * C + c)] = float(sh);
      }
    }
  }

  struct Out {  // where a normalised, activated result goes
    void* base = nullptr;
    bool bf16 = false;
    int64_t ld = 0;   // channels per pixel of the destination buffer
    int64_t off = 0;  // first channel
    bool relu = false;
  };

  // planes: 1 (dst side = side_) or 4 parity planes (dst side = 2 side_,
  // plane p = (py, px) lands on pixel (2i+py, 2j+px)).
  void norm_act(const NormState& nm, const std::vector<float*>& planes, int64_t side_, int64_t C, int act,
                const Out& o1, const Out* o2) {
    std::vector<float> scale, shift;
    bool per_image = false;
    norm_coeffs(nm, planes, side_, C, scale, shift, per_image);
    const int64_t N = o.batch, P = int64_t(planes.size()), rows = N * P * side_;
    const int64_t dside = P == 4 ? 2 * side_ : side_;
    at::parallel_for(0, rows, kRowGrain, [&](int64_t b0, int64_t b1) {
      std::vector<float> y(size_t(side_ * C));
      for (int64_t r = b0; r < b1; ++r) {
        const int64_t n = r / (P * side_), p = (r / side_) % P, i = r % side_;
        const int64_t py = P == 4 ? p / 2 : 0, px = P == 4 ? p % 2 : 0;
        const float* sc = &scale[size_t((per_image ? n : 0) * C)];
        const float* sh = &shift[size_t((per_image ? n : 0) * C)];
        affine_act_row(planes[size_t(p)] + ((n * side_ + i) * side_) * C, y.data(), side_, C, sc, sh, act);
        const int64_t dy = P == 4 ? 2 * i + py : i;
        for (const Out* d : {&o1, o2}) {
          if (!d) continue;
          const int64_t first = ((n * dside + dy) * dside + px) * d->ld + d->off;
          const int64_t stride = (P == 4 ? 2 : 1) * d->ld;
          if (d->bf16) store_row_bf16(y.data(), side_, C, static_cast<bf16_t*>(d->base) + first, stride, d->relu);
          else store_row_f32(y.data(), side_, C, static_cast<float*>(d->base) + first, stride, d->relu);
        }
      }
    });
  }

  // ×2 resize of src (nhwc, C channels, side s, f32 or bf16) into dst (same type).
  void upsample(dnnl::memory& src, dnnl::memory& dst, int64_t s, int64_t C, bool bf16) {
    const bool bilinear = u.upsample == Upsample::Bilinear;
    const int64_t N = o.batch, rows = N * 2 * s;
    at::parallel_for(0, rows, kRowGrain, [&](int64_t b0, int64_t b1) {
      std::vector<float> r0f, r1f, outf;
      if (bf16) r0f.resize(size_t(s * C)), r1f.resize(size_t(s * C)), outf.resize(size_t(2 * s * C));
      for (int64_t r = b0; r < b1; ++r) {
        const int64_t n = r / (2 * s), oy = r % (2 * s);
        int64_t i0 = oy >> 1, i1 = i0;
        float wy0 = 1.f, wy1 = 0.f;
        if (bilinear) {
          const float t = std::max(0.f, (oy + 0.5f) * 0.5f - 0.5f);
          i0 = int64_t(t);
          i1 = std::min(i0 + 1, s - 1);
          wy1 = t - float(i0);
          wy0 = 1.f - wy1;
        }
        if (!bf16) {
          const float* in = static_cast<const float*>(src.get_data_handle()) + n * s * s * C;
          float* out = static_cast<float*>(dst.get_data_handle()) + (n * 2 * s + oy) * 2 * s * C;
          upsample_row_f32(in + i0 * s * C, in + i1 * s * C, wy0, wy1, s, C, out, bilinear);
        } else {
          const bf16_t* in = static_cast<const bf16_t*>(src.get_data_handle()) + n * s * s * C;
          bf16_to_f32(in + i0 * s * C, r0f.data(), s * C);
          bf16_to_f32(in + i1 * s * C, r1f.data(), s * C);
          upsample_row_f32(r0f.data(), r1f.data(), wy0, wy1, s, C, outf.data(), bilinear);
          bf16_t* out = static_cast<bf16_t*>(dst.get_data_handle()) + (n * 2 * s + oy) * 2 * s * C;
          f32_to_bf16(outf.data(), out, 2 * s * C);
        }
      }
    });
  }

  // The output layer, fused with tanh: cat[0] (f32 nhwc, C channels, side
  // s = S/2) -> out nchw {N,out,S,S}. Its few output channels would waste
  // most of a blocked convolution, so the channels are contracted first, on
  // the s grid: taps[pixel][oc][t] = cat0[pixel] · w[oc][t] for the K×K
  // kernel taps t (dense dot products, the input row stays in cache); each
  // output pixel then sums a few of these scalars.
  // Transposed 4×4 stride 2: output (2m+py, 2n+px) takes 2×2 input pixels of
  // its parity. Resize (conv3×3 of the ×2 upsampled input; both are linear and
  // act per pixel): the nine tap maps are upsampled on the fly — a quarter of
  // the work of convolving at S. Exact up to float rounding.
  void output_layer(const float* src, int64_t C, float* out) {
    const int64_t N = o.batch, S = o.size_px, s = S / 2, OC = u.out_channels;
    const bool tr = u.upsample == Upsample::Transpose;
    const int64_t T = tr ? 16 : 9;
    const float* wt = out_wt.data_ptr<float>();
    const float* b = out_b.data_ptr<float>();
    const int64_t TT = OC * T, TTp = out_wt.size(1);
    std::vector<float> taps(size_t(N * s * s * TT));
    at::parallel_for(0, N * s * s, 64, [&](int64_t b0, int64_t b1) {
      taps_rows(src + b0 * C, b1 - b0, C, wt, TT, TTp, &taps[size_t(b0 * TT)]);
    });
    if (tr) {
      at::parallel_for(0, N * OC * S, kRowGrain, [&](int64_t b0, int64_t b1) {
        for (int64_t r = b0; r < b1; ++r) {
          const int64_t n = r / (OC * S), oc = (r / S) % OC, y = r % S;
          const float* tp = taps.data() + n * s * s * OC * T + oc * T;
          // Row y = 2m+py: input rows m-1 (kernel row 3), m (1) when py = 0;
          // m (2), m+1 (0) when py = 1. Columns alike.
          const int64_t m = y >> 1, py = y & 1;
          const int64_t iy[2] = {py ? m : m - 1, py ? m + 1 : m}, ky[2] = {py ? 2 : 3, py ? 0 : 1};
          for (int64_t x = 0; x < S; ++x) {
            const int64_t mx = x >> 1, px = x & 1;
            const int64_t ix[2] = {px ? mx : mx - 1, px ? mx + 1 : mx}, kx[2] = {px ? 2 : 3, px ? 0 : 1};
            float acc = 0.f;
            for (int a = 0; a < 2; ++a) {
              if (iy[a] < 0 || iy[a] >= s) continue;
              for (int c = 0; c < 2; ++c)
                if (ix[c] >= 0 && ix[c] < s) acc += tp[(iy[a] * s + ix[c]) * OC * T + ky[a] * 4 + kx[c]];
            }
            out[r * S + x] = std::tanh(acc + b[oc]);
          }
        }
      });
      return;
    }
    // Source index and weights of each upsampled coordinate, as PyTorch's
    // interpolation computes them (align_corners=false; nearest = floor(o/2)).
    std::vector<int64_t> i0(static_cast<size_t>(S)), i1(static_cast<size_t>(S));
    std::vector<float> w0(static_cast<size_t>(S)), w1(static_cast<size_t>(S));
    const bool bilinear = u.upsample == Upsample::Bilinear;
    for (int64_t q = 0; q < S; ++q) {
      if (bilinear) {
        const float t = std::max(0.f, (q + 0.5f) * 0.5f - 0.5f);
        i0[size_t(q)] = int64_t(t);
        i1[size_t(q)] = std::min(i0[size_t(q)] + 1, s - 1);
        w1[size_t(q)] = t - float(i0[size_t(q)]);
        w0[size_t(q)] = 1.f - w1[size_t(q)];
      } else {
        i0[size_t(q)] = i1[size_t(q)] = q >> 1;
        w0[size_t(q)] = 1.f;
        w1[size_t(q)] = 0.f;
      }
    }
    at::parallel_for(0, N * OC * S, kRowGrain, [&](int64_t b0, int64_t b1) {
      for (int64_t r = b0; r < b1; ++r) {
        const int64_t n = r / (OC * S), oc = (r / S) % OC, y = r % S;
        const float* tp = taps.data() + n * s * s * OC * 9 + oc * 9;
        for (int64_t x = 0; x < S; ++x) {
          float acc = 0.f;
          for (int64_t dy = 0; dy < 3; ++dy) {
            const int64_t yy = y + dy - 1;
            if (yy < 0 || yy >= S) continue;
            const size_t Y = size_t(yy);
            for (int64_t dx = 0; dx < 3; ++dx) {
              const int64_t xx = x + dx - 1;
              if (xx < 0 || xx >= S) continue;
              const size_t X = size_t(xx);
              const int64_t t = dy * 3 + dx;
              auto at = [&](int64_t i, int64_t j) { return tp[(i * s + j) * OC * 9 + t]; };
              acc += (at(i0[Y], i0[X]) * w0[X] + at(i0[Y], i1[X]) * w1[X]) * w0[Y] +
                     (at(i1[Y], i0[X]) * w0[X] + at(i1[Y], i1[X]) * w1[X]) * w1[Y];
            }
          }
          out[r * S + x] = std::tanh(acc + b[oc]);
        }
      }
    });
  }
};

std::string winograd_gemm_name() { return winograd_gemm() == WinogradGemm::Sgemm ? "sgemm" : "matmul"; }

std::string fast_unet_unsupported(UNetGeneratorImpl& g) {
  const auto& u = g.options();
  const bool any_dropout = u.depth >= 6 && u.dropout > 0;
  if (g.is_training() && g.dropout_enabled() && any_dropout) return "dropout is on (stochastic inference)";
  return "";
}

// Long: one walk over the U-Net's layers in forward()'s order, packing each
// level's weights and sizing its buffers (marked: buffers, encoder, decoder,
// output); split, each part would re-derive the level geometry.
FastUNet::FastUNet(UNetGeneratorImpl& g, const FastUNetOptions& options) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.o = options;
  m.u = g.options();
  const auto& u = m.u;
  const std::string why = fast_unet_unsupported(g);
  if (!why.empty()) throw std::invalid_argument("fast engine: " + why);
  if (m.o.batch < 1 || m.o.batch > 64) throw std::invalid_argument("FastUNetOptions: batch must be in [1, 64]");
  if (m.o.size_px < 32 || m.o.size_px > 4096 || m.o.size_px % (1 << u.depth))
    throw std::invalid_argument("FastUNetOptions: size_px must be in [32, 4096] and a multiple of 2^depth = " +
                                std::to_string(1 << u.depth));
  m.batch_stats = g.is_training();
  m.ct = m.o.precision == FastPrecision::Bf16 ? dt::bf16 : dt::f32;
  if (m.ct == dt::bf16) require_bf16_convolution("use --precision fp32 or auto");
  torch::NoGradGuard no_grad;
  auto params = g.named_parameters(true);
  auto buffers = g.named_buffers(true);
  auto P = [&](const std::string& name) -> torch::Tensor {
    if (auto* t = params.find(name)) return t->detach().to(torch::kFloat32);
    if (auto* t = buffers.find(name)) return t->detach().to(torch::kFloat32);
    return {};
  };
  auto norm_of = [&](const std::string& prefix) {
    NormState n;
    n.kind = u.norm;
    auto vec = [&](const std::string& name) {
      torch::Tensor t = P(name);
      if (!t.defined()) throw std::runtime_error("fast engine: generator has no " + name);
      t = t.to(torch::kFloat64).contiguous();
      return std::vector<double>(t.data_ptr<double>(), t.data_ptr<double>() + t.numel());
    };
    if (u.norm == Norm::Batch) {
      n.gamma = vec(prefix + ".bn.weight");
      n.beta = vec(prefix + ".bn.bias");
      n.running_mean = vec(prefix + ".bn.running_mean");
      n.running_var = vec(prefix + ".bn.running_var");
    }
    return n;
  };
  const int D = u.depth;
  const int64_t N = m.o.batch, S = m.o.size_px;
  const dt ct = m.ct;
  auto lv = [](int k) { return "levels." + std::to_string(k); };
  // Buffers.
  m.x_in = dnnl::memory(nhwc(N, u.in_channels, S, ct), m.eng);
  m.dconv.resize(size_t(D));
  m.act.resize(size_t(D));
  m.cat.resize(size_t(D));
  m.ups.resize(size_t(D));
  m.upout.resize(size_t(D));
  for (int k = 0; k < D; ++k) {
    m.dconv[size_t(k)] = dnnl::memory(nhwc(N, m.ch(k), m.side(k), dt::f32), m.eng);
    if (k < D - 1) {
      m.act[size_t(k)] = dnnl::memory(nhwc(N, m.ch(k), m.side(k), ct), m.eng);
      // The output layer reads cat[0] in float32 (bf16 rounding there alone
      // would cost more than a metre near the top of the range).
      m.cat[size_t(k)] = dnnl::memory(nhwc(N, 2 * m.ch(k), m.side(k), k == 0 ? dt::f32 : ct), m.eng);
    }
  }
  m.inner = dnnl::memory(nhwc(N, m.ch(D - 1), m.side(D - 1), ct), m.eng);
  // Encoder convolutions: 4×4 stride 2 pad 1.
  for (int k = 0; k < D; ++k) {
    m.down.push_back(m.make_conv(P(lv(k) + ".down_conv.weight"), P(lv(k) + ".down_conv.bias"),
                                 k == 0 ? S : m.side(k - 1), ct, 2, {1, 1}, {1, 1}));
    m.down_norm.push_back(k > 0 && k < D - 1 ? norm_of(lv(k) + ".down_norm") : NormState{});
  }
  // Decoder convolutions of levels 1..D-1.
  m.up.resize(size_t(D));
  m.wino.resize(size_t(D));
  const bool winograd = m.o.winograd && ct == dt::f32;
  const WinogradGemm wgemm = winograd ? winograd_gemm() : WinogradGemm::Matmul;
  m.up_norm.resize(size_t(D));
  m.up_convs_flat.reserve(size_t(4 * D));
  for (int k = D - 1; k >= 1; --k) {
    const int64_t s = m.side(k), out = m.ch(k - 1);
    m.up_norm[size_t(k)] = norm_of(lv(k) + ".up_norm");
    const torch::Tensor w = P(lv(k) + ".up_conv.weight"), b = P(lv(k) + ".up_conv.bias");
    if (u.upsample == Upsample::Transpose) {
      // Transposed weights {in,out,4,4}. Output parity py takes kernel rows
      // {3,1} over input rows {m-1,m} (py = 0) or {2,0} over {m,m+1} (py = 1):
      // a 2×2 convolution padded on top (py = 0) or at the bottom (py = 1).
      // Levels large enough run all four as Winograd GEMMs instead.
      if (winograd && s >= winograd_min_side(wgemm))
        m.wino[size_t(k)] = std::make_unique<ParityWinograd>(w, b, N, s, m.eng, wgemm);
      for (int py = 0; py < 2; ++py)
        for (int px = 0; px < 2; ++px) {
          m.upout[size_t(k)].push_back(dnnl::memory(nhwc(N, out, s, dt::f32), m.eng));
          if (m.wino[size_t(k)]) continue;
          const auto iy = torch::tensor(py ? std::vector<int64_t>{2, 0} : std::vector<int64_t>{3, 1});
          const auto ix = torch::tensor(px ? std::vector<int64_t>{2, 0} : std::vector<int64_t>{3, 1});
          const torch::Tensor wp = w.index_select(2, iy).index_select(3, ix).transpose(0, 1).contiguous();
          m.up_convs_flat.push_back(m.make_conv(wp, b, s, ct, 1, {py ? 0 : 1, px ? 0 : 1}, {py, px}));
          m.up[size_t(k)].push_back(&m.up_convs_flat.back());
        }
    } else {
      const int64_t in = k == D - 1 ? m.ch(k) : 2 * m.ch(k);
      m.ups[size_t(k)] = dnnl::memory(nhwc(N, in, 2 * s, ct), m.eng);
      m.up_convs_flat.push_back(m.make_conv(w, b, 2 * s, ct, 1, {1, 1}, {1, 1}));
      m.up[size_t(k)].push_back(&m.up_convs_flat.back());
      m.upout[size_t(k)].push_back(dnnl::memory(nhwc(N, out, 2 * s, dt::f32), m.eng));
    }
  }
  // Output layer, weights as {in, (out, kh, kw)}: a row of taps per input channel.
  {
    const torch::Tensor w = P(lv(0) + ".up_conv.weight").to(torch::kFloat32);
    // ConvTranspose2d holds {in, out, kh, kw} already; Conv2d {out, in, kh, kw}.
    const torch::Tensor io = u.upsample == Upsample::Transpose ? w : w.transpose(0, 1);
    const torch::Tensor rows = io.reshape({io.size(0), -1});
    const int64_t tt = rows.size(1), ttp = (tt + kTapLanes - 1) / kTapLanes * kTapLanes;
    m.out_wt = torch::zeros({rows.size(0), ttp});
    m.out_wt.narrow(1, 0, tt).copy_(rows);
    m.out_b = P(lv(0) + ".up_conv.bias").contiguous();
  }
}

FastUNet::~FastUNet() = default;

const FastUNetOptions& FastUNet::options() const { return impl_->o; }

torch::Tensor FastUNet::forward(const torch::Tensor& x_) {
  Impl& m = *impl_;
  const auto& u = m.u;
  const int D = u.depth;
  const int64_t N = m.o.batch, S = m.o.size_px, C0 = u.in_channels;
  if (x_.dim() != 4 || x_.size(0) != N || x_.size(1) != C0 || x_.size(2) != S || x_.size(3) != S)
    throw std::invalid_argument("FastUNet: input must be {" + std::to_string(N) + "," + std::to_string(C0) + "," +
                                std::to_string(S) + "," + std::to_string(S) + "}, got " + c10::str(x_.sizes()));
  const bool bf = m.ct == dt::bf16;
  // nchw float -> nhwc compute type.
  {
    const torch::Tensor x = x_.to(torch::kFloat32).permute({0, 2, 3, 1}).contiguous();  // {N,S,S,C0}
    const float* xs = x.data_ptr<float>();
    const int64_t n = x.numel();
    if (bf) {
      f32_to_bf16(xs, static_cast<bf16_t*>(m.ptr(m.x_in)), n);
    } else {
      std::memcpy(m.ptr(m.x_in), xs, size_t(n) * 4);
    }
  }
  // Encoder. Level k's output d is activated once for the next convolution
  // (leaky) and once for the decoder's concatenation (relu(leaky(d)) = relu(d)).
  for (int k = 0; k < D; ++k) {
    m.down[size_t(k)].run(m.strm, k == 0 ? m.x_in : m.act[size_t(k - 1)], m.dconv[size_t(k)]);
    m.strm.wait();
    const int64_t C = m.ch(k), s = m.side(k);
    std::vector<float*> plane{static_cast<float*>(m.ptr(m.dconv[size_t(k)]))};
    if (k == D - 1) {  // innermost: no norm, relu before the up path
      Impl::Out o{m.ptr(m.inner), bf, C, 0, false};
      m.norm_act(NormState{}, plane, s, C, kRelu, o, nullptr);
    } else {
      Impl::Out a{m.ptr(m.act[size_t(k)]), bf, C, 0, false};
      Impl::Out c{m.ptr(m.cat[size_t(k)]), bf && k > 0, 2 * C, 0, true};
      m.norm_act(m.down_norm[size_t(k)], plane, s, C, kLeakyRelu, a, &c);
    }
  }
  // Decoder: level k's up output, normalised and relu'd (the next level's
  // relu on the concatenation), lands in the second half of cat[k-1].
  for (int k = D - 1; k >= 1; --k) {
    dnnl::memory& src = k == D - 1 ? m.inner : m.cat[size_t(k)];
    const int64_t out = m.ch(k - 1), s = m.side(k);
    std::vector<float*> planes;
    if (u.upsample == Upsample::Transpose) {
      for (size_t p = 0; p < 4; ++p) {
        if (!m.wino[size_t(k)]) m.up[size_t(k)][p]->run(m.strm, src, m.upout[size_t(k)][p]);
        planes.push_back(static_cast<float*>(m.ptr(m.upout[size_t(k)][p])));
      }
      if (m.wino[size_t(k)]) m.wino[size_t(k)]->run(static_cast<const float*>(m.ptr(src)), planes.data(), m.strm);
      m.strm.wait();
      Impl::Out c{m.ptr(m.cat[size_t(k - 1)]), bf && k > 1, 2 * out, out, false};
      m.norm_act(m.up_norm[size_t(k)], planes, s, out, kRelu, c, nullptr);
    } else {
      const int64_t in = k == D - 1 ? m.ch(k) : 2 * m.ch(k);
      m.upsample(src, m.ups[size_t(k)], s, in, bf);
      m.up[size_t(k)][0]->run(m.strm, m.ups[size_t(k)], m.upout[size_t(k)][0]);
      m.strm.wait();
      planes.push_back(static_cast<float*>(m.ptr(m.upout[size_t(k)][0])));
      Impl::Out c{m.ptr(m.cat[size_t(k - 1)]), bf && k > 1, 2 * out, out, false};
      m.norm_act(m.up_norm[size_t(k)], planes, 2 * s, out, kRelu, c, nullptr);
    }
  }
  torch::Tensor y = torch::empty({N, u.out_channels, S, S});  // {N,out,S,S}
  const int64_t C = 2 * m.ch(0);
  m.output_layer(static_cast<const float*>(m.ptr(m.cat[0])), C, y.data_ptr<float>());
  return y;
}

}  // namespace reefgen::model
