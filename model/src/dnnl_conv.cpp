#include "reefgen/model/dnnl_conv.hpp"


#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <tuple>

#include <oneapi/dnnl/dnnl.hpp>

#include "reefgen/cpu.hpp"

namespace reefgen::model {

namespace {
bool dnnl_isa_has(dnnl::cpu_isa want) {
  const auto have = static_cast<unsigned>(dnnl::get_effective_cpu_isa());
  return (have & static_cast<unsigned>(want)) == static_cast<unsigned>(want);
}
}  // namespace

// The CPU's own instructions (cpu.hpp), unless hidden by REEFGEN_NO_BF16 or
// capped below them by DNNL_MAX_CPU_ISA: what oneDNN will really run.
bool cpu_has_native_bf16() {
  const CpuFeatures& f = cpu_features();
  if (cpu_bf16_hidden()) return false;
  return (f.amx_bf16 && dnnl_isa_has(dnnl::cpu_isa::avx512_core_amx)) ||
         (f.avx512_bf16 && dnnl_isa_has(dnnl::cpu_isa::avx512_core_bf16));
}

bool cpu_has_amx_bf16() {
  return !cpu_bf16_hidden() && cpu_features().amx_bf16 && dnnl_isa_has(dnnl::cpu_isa::avx512_core_amx);
}

// oneDNN 2.6 builds bf16 convolutions from avx512_core up (emulating the
// bf16 instructions where the CPU lacks them), never on AVX2: so bf16 is
// offered on every AVX-512 CPU and refused with one line below it.
bool bf16_convolution_available() { return !cpu_bf16_hidden() && dnnl_isa_has(dnnl::cpu_isa::avx512_core); }

void require_bf16_convolution(const std::string& fix) {
  if (bf16_convolution_available()) return;
  throw std::runtime_error(std::string("oneDNN cannot build a bf16 convolution on this CPU (") + cpu_summary() +
                           "; bf16 needs AVX-512): " + fix);
}

namespace {

using dt = dnnl::memory::data_type;
using tag = dnnl::memory::format_tag;
using dims = dnnl::memory::dims;

dnnl::engine& cpu_engine() {
  static dnnl::engine e(dnnl::engine::kind::cpu, 0);
  return e;
}
dnnl::stream& cpu_stream() {
  thread_local dnnl::stream s(cpu_engine());
  return s;
}

// One layer shape: the three primitives and the user-side (LibTorch) layouts.
struct Key {
  int64_t n, cin, h, w, cout, k, stride, pad;
  bool transposed, bf16, bias, plain;
  auto tie() const { return std::tie(n, cin, h, w, cout, k, stride, pad, transposed, bf16, bias, plain); }
  bool operator<(const Key& o) const { return tie() < o.tie(); }
};

struct Prims {
  dnnl::memory::desc src_user, dst_user, w_user, b_user;
  dnnl::memory::desc src, dst, w_fwd, w_bwd, diff_dst_d, diff_src, src_w, diff_dst_w, diff_w, diff_b;
  dnnl::primitive fwd, bwd_data, bwd_weights;
  int64_t oh = 0, ow = 0;
};

int64_t out_side(int64_t in, const Key& k) {
  return k.transposed ? (in - 1) * k.stride - 2 * k.pad + k.k : (in + 2 * k.pad - k.k) / k.stride + 1;
}

template <class Fwd, class BwdData, class BwdWeights>
void build(Prims& p, dnnl::algorithm alg, const Key& k) {
  using FwdDesc = typename Fwd::desc;
  using BwdDataDesc = typename BwdData::desc;
  using BwdWeightsDesc = typename BwdWeights::desc;
  using FwdPd = typename Fwd::primitive_desc;
  using BwdDataPd = typename BwdData::primitive_desc;
  using BwdWeightsPd = typename BwdWeights::primitive_desc;
  auto& eng = cpu_engine();
  const dt c = k.bf16 ? dt::bf16 : dt::f32;
  const dims src_d{k.n, k.cin, k.h, k.w}, dst_d{k.n, k.cout, p.oh, p.ow}, w_d{k.cout, k.cin, k.k, k.k}, b_d{k.cout};
  const dims st{k.stride, k.stride}, pad{k.pad, k.pad};
  // Plain layers take LibTorch's weight layout as it is (oneDNN then runs a
  // GEMM): nothing to pack or unpack.
  const tag w_tag = k.plain ? (k.transposed ? tag::iohw : tag::oihw) : tag::any;
  const dnnl::memory::desc src_any(src_d, c, tag::any), w_any(w_d, c, w_tag), dst_any(dst_d, dt::f32, tag::any),
      diff_dst_any(dst_d, c, tag::any), diff_src_any(src_d, dt::f32, tag::any), diff_w_any(w_d, dt::f32, w_tag),
      b_any(b_d, dt::f32, tag::any);
  const auto fwd_desc = k.bias ? FwdDesc(dnnl::prop_kind::forward_training, alg, src_any, w_any, b_any, dst_any, st, pad, pad)
                               : FwdDesc(dnnl::prop_kind::forward_training, alg, src_any, w_any, dst_any, st, pad, pad);
  FwdPd fpd(fwd_desc, eng);
  BwdDataPd dpd(BwdDataDesc(alg, diff_src_any, w_any, diff_dst_any, st, pad, pad), eng, fpd);
  const auto bw_desc = k.bias ? BwdWeightsDesc(alg, src_any, diff_w_any, b_any, diff_dst_any, st, pad, pad)
                              : BwdWeightsDesc(alg, src_any, diff_w_any, diff_dst_any, st, pad, pad);
  BwdWeightsPd wpd(bw_desc, eng, fpd);
  p.src = fpd.src_desc();
  p.w_fwd = fpd.weights_desc();
  p.dst = fpd.dst_desc();
  p.w_bwd = dpd.weights_desc();
  p.diff_dst_d = dpd.diff_dst_desc();
  p.diff_src = dpd.diff_src_desc();
  p.src_w = wpd.src_desc();
  p.diff_dst_w = wpd.diff_dst_desc();
  p.diff_w = wpd.diff_weights_desc();
  if (k.bias) p.diff_b = wpd.diff_bias_desc();
  p.fwd = Fwd(fpd);
  p.bwd_data = BwdData(dpd);
  p.bwd_weights = BwdWeights(wpd);
}

std::mutex g_mutex;  // guards the two caches below

const Prims& prims(const Key& k) {
  static std::map<Key, Prims> cache;
  std::lock_guard<std::mutex> lock(g_mutex);
  auto it = cache.find(k);
  if (it != cache.end()) return it->second;
  Prims p;
  p.oh = out_side(k.h, k);
  p.ow = out_side(k.w, k);
  if (p.oh < 1 || p.ow < 1) throw std::invalid_argument("dnnl_conv2d: the input is smaller than the kernel");
  p.src_user = dnnl::memory::desc({k.n, k.cin, k.h, k.w}, dt::f32, tag::nchw);
  p.dst_user = dnnl::memory::desc({k.n, k.cout, p.oh, p.ow}, dt::f32, tag::nchw);
  // LibTorch stores a transposed convolution's weights {in, out, k, k}.
  p.w_user = dnnl::memory::desc({k.cout, k.cin, k.k, k.k}, dt::f32, k.transposed ? tag::iohw : tag::oihw);
  p.b_user = dnnl::memory::desc({k.cout}, dt::f32, tag::a);
  try {
    if (k.transposed)
      build<dnnl::deconvolution_forward, dnnl::deconvolution_backward_data, dnnl::deconvolution_backward_weights>(
          p, dnnl::algorithm::deconvolution_direct, k);
    else
      build<dnnl::convolution_forward, dnnl::convolution_backward_data, dnnl::convolution_backward_weights>(
          p, dnnl::algorithm::convolution_direct, k);
  } catch (const dnnl::error& e) {
    throw std::runtime_error(std::string("oneDNN cannot build a ") + (k.bf16 ? "bf16 " : "") +
                             (k.transposed ? "transposed " : "") + "convolution of this shape (" + e.what() +
                             "); train with --precision fp32 or --engine torch");
  }
  return cache.emplace(k, std::move(p)).first->second;
}

// A buffer LibTorch owns (so autograd can keep it) viewed as oneDNN memory.
struct Buf {
  torch::Tensor t;
  dnnl::memory m;
};
Buf alloc(const dnnl::memory::desc& d) {
  Buf b;
  b.t = torch::empty({int64_t(d.get_size())}, torch::kUInt8);
  b.m = dnnl::memory(d, cpu_engine(), b.t.data_ptr());
  return b;
}
dnnl::memory wrap(const dnnl::memory::desc& d, const torch::Tensor& t) {
  return dnnl::memory(d, cpu_engine(), t.data_ptr());
}
// `from` in the layout `want`: itself if it already is, else a reordered copy.
Buf packed(dnnl::memory from, const torch::Tensor& owner, const dnnl::memory::desc& want) {
  if (from.get_desc() == want) return {owner, from};
  Buf b = alloc(want);
  dnnl::reorder(from, b.m).execute(cpu_stream(), from, b.m);
  return b;
}
void reorder_into(dnnl::memory from, dnnl::memory to) {
  dnnl::reorder(from, to).execute(cpu_stream(), from, to);
}

// Packed weights, one copy per (parameter, layout), valid while the
// parameter's storage and version counter are unchanged: every in-place
// update (optimiser steps, loading, init) bumps the version.
struct WeightEntry {
  std::optional<c10::weak_intrusive_ptr<c10::TensorImpl>> owner;
  bool expired() const { return !owner || owner->expired(); }
  const void* data = nullptr;
  uint32_t version = 0;
  Buf buf;
};
// Per parameter, one entry per packed layout (a layer's forward and backward
// layouts differ; equal layouts share one copy).
std::multimap<const void*, WeightEntry>& weight_cache() {
  static std::multimap<const void*, WeightEntry> c;
  return c;
}

dnnl::memory packed_weights(const torch::Tensor& w, const Prims& p, const dnnl::memory::desc& want) {
  const dnnl::memory user = wrap(p.w_user, w);
  if (want == p.w_user) return user;
  std::lock_guard<std::mutex> lock(g_mutex);
  auto& cache = weight_cache();
  // Copies of freed parameters go first (their address may be reused).
  for (auto it = cache.begin(); it != cache.end();) it = it->second.expired() ? cache.erase(it) : std::next(it);
  WeightEntry* found = nullptr;
  auto [lo, hi] = cache.equal_range(w.unsafeGetTensorImpl());
  for (auto it = lo; it != hi && !found; ++it)
    if (it->second.buf.t.defined() && it->second.buf.m.get_desc() == want) found = &it->second;
  WeightEntry& e = found ? *found : cache.emplace(w.unsafeGetTensorImpl(), WeightEntry{})->second;
  const uint32_t version = w._version();
  if (!e.expired() && e.data == w.data_ptr() && e.version == version && e.buf.m.get_desc() == want)
    return e.buf.m;
  e.owner.emplace(w.getIntrusivePtr());
  e.data = w.data_ptr();
  e.version = version;
  // The same layout as before (an optimiser step): repack in place, no fresh
  // pages to fault in.
  if (!e.buf.t.defined()) e.buf = alloc(want);
  reorder_into(user, e.buf.m);
  return e.buf.m;
}

// Where a layer has few positions per image (pix2pix's 512-channel levels
// near the bottleneck: ≤ 8×8), its cost is moving the weights, not
// arithmetic: oneDNN's blocked kernels would repack 16–32 MiB of weights
// three times per step for a few MFLOP, so those layers keep the plain layout
// (measured, docs/BENCHMARKS.md: 1.3–3× faster there, slower above 8×8).
constexpr int64_t kPlainMaxPositions = 64;

Key key_of(const torch::Tensor& x, const torch::Tensor& w, bool bias, int64_t stride, int64_t pad, bool transposed,
           bool bf16) {
  const int64_t cout = transposed ? w.size(1) : w.size(0), k = w.size(2);
  Key key{x.size(0), x.size(1), x.size(2), x.size(3), cout, k, stride, pad, transposed, bf16, bias, false};
  // Positions where the weights are applied: input pixels of a transposed
  // convolution, output pixels of a convolution.
  const int64_t positions = transposed ? key.h * key.w : out_side(key.h, key) * out_side(key.w, key);
  key.plain = positions <= kPlainMaxPositions && cout > 1;
  return key;
}

struct DnnlConvFn : torch::autograd::Function<DnnlConvFn> {
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, torch::Tensor x, torch::Tensor w,
                               torch::Tensor b, int64_t stride, int64_t pad, bool transposed, bool bf16) {
    x = x.contiguous();
    const bool bias = b.numel() > 0;  // an empty tensor stands for "no bias" (autograd needs defined inputs)
    const Key k = key_of(x, w, bias, stride, pad, transposed, bf16);
    const Prims& p = prims(k);
    const Buf src = packed(wrap(p.src_user, x), x, p.src);
    const dnnl::memory wm = packed_weights(w, p, p.w_fwd);
    torch::Tensor y = torch::empty({k.n, k.cout, p.oh, p.ow});  // {N,Cout,OH,OW}
    const dnnl::memory y_user = wrap(p.dst_user, y);
    const Buf dst = p.dst == p.dst_user ? Buf{y, y_user} : alloc(p.dst);
    std::unordered_map<int, dnnl::memory> args{{DNNL_ARG_SRC, src.m}, {DNNL_ARG_WEIGHTS, wm}, {DNNL_ARG_DST, dst.m}};
    torch::Tensor bc;
    if (bias) {
      bc = b.contiguous();
      args.insert({DNNL_ARG_BIAS, wrap(p.b_user, bc)});
    }
    p.fwd.execute(cpu_stream(), args);
    if (dst.t.data_ptr() != y.data_ptr()) reorder_into(dst.m, y_user);
    // The packed input is what backward-weights reads: kept instead of
    // reordering x again.
    ctx->save_for_backward({x, w});
    ctx->saved_data["src"] = (w.requires_grad() && p.src_w == p.src) ? src.t : torch::Tensor();
    ctx->saved_data["geom"] = std::vector<int64_t>{stride, pad, transposed, bf16, bias};
    return y;
  }

  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    const torch::Tensor x = saved[0], w = saved[1];
    const auto g = ctx->saved_data["geom"].toIntVector();
    const Key k = key_of(x, w, g[4] != 0, g[0], g[1], g[2] != 0, g[3] != 0);
    const Prims& p = prims(k);
    const torch::Tensor gy = grads[0].contiguous();  // {N,Cout,OH,OW}
    const dnnl::memory gy_user = wrap(p.dst_user, gy);
    torch::Tensor dx, dw, db;
    Buf gy_d;
    if (ctx->needs_input_grad(0)) {
      gy_d = packed(gy_user, gy, p.diff_dst_d);
      dx = torch::empty_like(x);
      const dnnl::memory dx_user = wrap(p.src_user, dx);
      const Buf diff_src = p.diff_src == p.src_user ? Buf{dx, dx_user} : alloc(p.diff_src);
      p.bwd_data.execute(cpu_stream(), {{DNNL_ARG_DIFF_DST, gy_d.m},
                                        {DNNL_ARG_WEIGHTS, packed_weights(w, p, p.w_bwd)},
                                        {DNNL_ARG_DIFF_SRC, diff_src.m}});
      if (diff_src.t.data_ptr() != dx.data_ptr()) reorder_into(diff_src.m, dx_user);
    }
    if (ctx->needs_input_grad(1) || ctx->needs_input_grad(2)) {
      const torch::Tensor src_saved = ctx->saved_data["src"].toTensor();
      const Buf src = src_saved.defined() ? Buf{src_saved, wrap(p.src_w, src_saved)} : packed(wrap(p.src_user, x), x, p.src_w);
      const Buf gy_w = (gy_d.t.defined() && p.diff_dst_w == p.diff_dst_d) ? gy_d : packed(gy_user, gy, p.diff_dst_w);
      dw = torch::empty_like(w);
      const dnnl::memory dw_user = wrap(p.w_user, dw);
      const Buf diff_w = p.diff_w == p.w_user ? Buf{dw, dw_user} : alloc(p.diff_w);
      std::unordered_map<int, dnnl::memory> args{
          {DNNL_ARG_SRC, src.m}, {DNNL_ARG_DIFF_DST, gy_w.m}, {DNNL_ARG_DIFF_WEIGHTS, diff_w.m}};
      Buf diff_b;
      if (k.bias) {
        db = torch::empty({k.cout});
        diff_b = p.diff_b == p.b_user ? Buf{db, wrap(p.b_user, db)} : alloc(p.diff_b);
        args.insert({DNNL_ARG_DIFF_BIAS, diff_b.m});
      }
      p.bwd_weights.execute(cpu_stream(), args);
      if (diff_w.t.data_ptr() != dw.data_ptr()) reorder_into(diff_w.m, dw_user);
      if (k.bias && diff_b.t.data_ptr() != db.data_ptr()) reorder_into(diff_b.m, wrap(p.b_user, db));
      if (!ctx->needs_input_grad(1)) dw = torch::Tensor();
      if (!ctx->needs_input_grad(2)) db = torch::Tensor();
    }
    return {dx, dw, db, torch::Tensor(), torch::Tensor(), torch::Tensor(), torch::Tensor()};
  }
};

}  // namespace

torch::Tensor dnnl_conv2d(const torch::Tensor& x, const torch::Tensor& w, const torch::Tensor& b,
                          const ConvGeometry& geo, ConvPrecision precision) {
  const int64_t cin = geo.transposed ? w.size(0) : w.size(1);
  if (x.dim() != 4 || w.dim() != 4 || x.size(1) != cin || w.size(2) != w.size(3) ||
      x.scalar_type() != torch::kFloat32 || w.scalar_type() != torch::kFloat32 || !x.device().is_cpu())
    throw std::invalid_argument("dnnl_conv2d: needs float32 CPU x {N,C,H,W} and square weights matching C; got x " +
                                c10::str(x.sizes()) + ", w " + c10::str(w.sizes()));
  if (b.defined() && (b.dim() != 1 || b.size(0) != (geo.transposed ? w.size(1) : w.size(0))))
    throw std::invalid_argument("dnnl_conv2d: bias must have one value per output channel");
  if (geo.stride < 1 || geo.padding < 0 || geo.padding >= w.size(2))
    throw std::invalid_argument("dnnl_conv2d: stride must be >= 1 and padding in [0, kernel)");
  if (precision == ConvPrecision::Bf16) require_bf16_convolution("train with --precision fp32 or auto");
  return DnnlConvFn::apply(x, w.contiguous(), b.defined() ? b : torch::empty({0}), geo.stride, geo.padding, geo.transposed,
                           precision == ConvPrecision::Bf16);
}

size_t dnnl_weight_cache_size() {
  std::lock_guard<std::mutex> lock(g_mutex);
  size_t n = 0;
  for (const auto& [k, e] : weight_cache()) n += e.expired() ? 0 : 1;
  return n;
}

}  // namespace reefgen::model
