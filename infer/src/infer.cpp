#include "reefgen/infer/infer.hpp"
#include "reefgen/infer/amplify.hpp"
#include "reefgen/infer/edge_repair.hpp"
#include "reefgen/infer/reef_details.hpp"
#include "reefgen/infer/variation.hpp"




#include <opencv2/imgproc.hpp>

#include "reefgen/interrupt.hpp"
#include "reefgen/parallel.hpp"
#include "reefgen/rng.hpp"

namespace reefgen::infer {

Precision precision_from_string(const std::string& s) {
  if (s == "auto") return Precision::Auto;
  if (s == "fp32") return Precision::Fp32;
  if (s == "bf16") return Precision::Bf16;
  throw Error("precision '" + s + "': use auto, fp32 or bf16");
}

const char* to_string(Precision p) {
  return p == Precision::Auto ? "auto" : p == Precision::Fp32 ? "fp32" : "bf16";
}

Precision resolve(Precision p) {
  if (p == Precision::Bf16) model::require_bf16_convolution("use --precision fp32 or auto");
  if (p != Precision::Auto) return p;
  // With the oneDNN engine bf16 runs the shipped model faster where the CPU
  // has native bf16 instructions (docs/BENCHMARKS.md); without them it would
  // be emulated, and below AVX-512 oneDNN has no bf16 convolution at all.
  return cpu_has_native_bf16() ? Precision::Bf16 : Precision::Fp32;
}

Engine engine_from_string(const std::string& s) {
  if (s == "auto") return Engine::Auto;
  if (s == "onednn") return Engine::OneDnn;
  if (s == "torch") return Engine::Torch;
  throw Error("engine '" + s + "': use auto, onednn or torch");
}

const char* to_string(Engine e) { return e == Engine::Auto ? "auto" : e == Engine::OneDnn ? "onednn" : "torch"; }

Engine resolve_engine(const InferOptions& o) {
  if (o.engine == Engine::OneDnn && o.stochastic)
    throw Error("the onednn engine has no dropout: --stochastic needs --engine torch or auto");
  if (o.engine != Engine::Auto) return o.engine;
  return o.stochastic ? Engine::Torch : Engine::OneDnn;
}

Precision resolve(const InferOptions& o, const model::GeneratorFile& g) {
  const Engine e = resolve_engine(o);
  // LibTorch 1.13's bf16 path (oneDNN) refuses the transposed convolution of
  // the 1×1 innermost level: on the torch engine pix2pix's decoder stays fp32.
  const bool resize = g.g->options().upsample != model::Upsample::Transpose;
  if (e == Engine::Torch && !resize) {
    if (o.precision == Precision::Bf16)
      throw Error("bf16 on the torch engine needs a resize-convolution generator (upsample nearest or "
                                  "bilinear); use --engine onednn, or --precision fp32 or auto");
    return Precision::Fp32;
  }
  return resolve(o.precision);
}

cv::Mat3b canonical_sketch(const DecodedSketch& s, int size_px) {
  cv::Mat1b label = s.label;
  cv::Mat1f sub = s.subsidence;
  if (label.rows != size_px || label.cols != size_px) {
    cv::resize(s.label, label, {size_px, size_px}, 0, 0, cv::INTER_NEAREST);
    cv::resize(s.subsidence, sub, {size_px, size_px}, 0, 0, cv::INTER_LINEAR);
  }
  return encode_labels(label, sub);
}

namespace {
// The layer of a bf16 copy that stays float32: the output convolution, whose
// bf16 rounding alone would be > 1 m near the top of the range. (Keeping the
// next one in float32 too did not measurably reduce the error: it comes from
// the bf16 weights and activations of the whole net.)
bool keep_fp32(const std::string& name) { return name.rfind("levels.0.up_conv.", 0) == 0; }
}  // namespace

torch::Tensor forward_generator(model::GeneratorFile& g, const torch::Tensor& x, Engine engine, Precision precision,
                                bool running_stats) {
  const int64_t n = x.size(0), side = x.size(3);
  torch::Tensor y;
  if (engine == Engine::OneDnn) {
    const bool train_mode = !running_stats;
    const std::string key = std::to_string(n) + "/" + std::to_string(side) + "/" +
                            (precision == Precision::Bf16 ? "bf16" : "fp32") + (train_mode ? "/batch" : "/running");
    auto& fast = g.fast[key];
    if (!fast) {
      g.g->train(train_mode);
      g.g->set_dropout_enabled(false);
      fast = std::make_shared<model::FastUNet>(
          *g.g, model::FastUNetOptions{int(n), int(side),
                                       precision == Precision::Bf16 ? model::FastPrecision::Bf16
                                                                    : model::FastPrecision::Fp32});
    }
    y = fast->forward(x);  // {n,1,S,S}
  } else if (precision == Precision::Bf16) {
    // A bf16 copy of G, made once per loaded file (same modes as g). The
    // output layer stays float32: bf16's 8-bit mantissa alone would round
    // heights near the top of the range by more than a metre.
    if (!g.g_bf16) {
      g.g_bf16 = model::UNetGenerator(g.g->options());
      auto dst = g.g_bf16->named_parameters(), src = g.g->named_parameters();
      for (auto& t : dst)
        t.value().set_data(keep_fp32(t.key()) ? src[t.key()].detach().clone()
                                               : src[t.key()].detach().to(torch::kBFloat16));
      auto dstb = g.g_bf16->named_buffers(), srcb = g.g->named_buffers();
      for (auto& t : dstb)
        t.value().set_data(srcb[t.key()].is_floating_point() ? srcb[t.key()].detach().to(torch::kBFloat16)
                                                               : srcb[t.key()].detach().clone());
    }
    g.g_bf16->train(g.g->is_training());
    g.g_bf16->set_dropout_enabled(g.g->dropout_enabled());
    y = g.g_bf16->forward(x.to(torch::kBFloat16)).to(torch::kFloat32);  // {n,1,S,S}
  } else {
    y = g.g->forward(x);  // {n,1,S,S}
  }
  return y;
}

DecodedSketch with_age(const DecodedSketch& s, double age_myr) {
  if (age_myr == kNotSet) return s;
  DecodedSketch a = s;
  a.subsidence = cv::Mat1f(s.subsidence.size(), float(subsidence_of_age(age_myr)));
  return a;
}

AmplifyParams amplification_of(const InferOptions& o) {
  const double m = maturity_for(o.age_myr, o.maturity);
  return m == kNotSet ? o.amplification : matured(o.amplification, m);
}

double network_maturity(const InferOptions& o) {
  const double m = maturity_for(o.age_myr, o.maturity);
  return m == kNotSet ? 1.0 : m;
}

namespace {

// The network's answers in metres at the model's side, one per sketch.
std::vector<cv::Mat1f> network_answers(model::GeneratorFile& g, const std::vector<DecodedSketch>& sketches,
                                       const InferOptions& o) {
  c10::InferenceMode inference;  // no autograd bookkeeping at all (cheaper than NoGradGuard)
  // pix2pix runs G in train mode at test time: BatchNorm normalises with the
  // sample's own statistics. With batch statistics a batch would mix samples,
  // so that mode runs one sketch per forward; running statistics batch freely.
  g.g->train(!o.running_stats);
  g.g->set_dropout_enabled(o.stochastic);
  const Engine engine = resolve_engine(o);
  const Precision precision = resolve(o, g);
  std::vector<torch::Tensor> inputs;
  for (const auto& s : sketches)
    inputs.push_back(model::network_input(canonical_sketch(with_age(s, o.age_myr), g.size_px),
                                          g.g->options().in_channels, network_maturity(o)));  // {in,S,S}
  std::vector<cv::Mat1f> answers;
  // Stochastic mode runs one sketch per forward with the masks of --seed, so a
  // sketch gives the same island alone or in a folder, in any position.
  const size_t batch = o.running_stats && !o.stochastic ? 8 : 1;
  for (size_t i = 0; i < inputs.size(); i += batch) {
    const size_t n = std::min(batch, inputs.size() - i);
    if (o.stochastic) torch::manual_seed(derive_seed(o.seed, 0, "infer-dropout"));
    const torch::Tensor x = torch::stack(std::vector<torch::Tensor>(inputs.begin() + long(i), inputs.begin() + long(i + n)));
    const torch::Tensor y = forward_generator(g, x, engine, precision, o.running_stats);  // {n,1,S,S}
    for (size_t k = 0; k < n; ++k) answers.push_back(model::tensor_to_height(y[long(k)], g.range));
  }
  return answers;
}

// One answer made the output: at o.size_px (default the sketch's size),
// re-rolled and amplified by o.seed when square and amplified, else resized.
cv::Mat1f finish_answer(cv::Mat1f h, const DecodedSketch& sketch, const InferOptions& o, const model::HeightRange& range,
                        std::vector<cv::Mat1f>* before) {
  const cv::Size want = o.size_px > 0 ? cv::Size(o.size_px, o.size_px) : sketch.label.size();
  if (before) {
    cv::Mat1f b;
    cv::resize(h, b, want, 0, 0, want.width > h.cols ? cv::INTER_CUBIC : cv::INTER_AREA);
    before->push_back(std::move(b));
  }
  // At every size the answer is cleaned (amplify_heights): at the
  // model's own side ponds raised and pits breached, above it
  // also eroded and refined; --raw (amplify off) keeps the network's bits.
  if (want.width == want.height && o.amplify && h.rows == h.cols) {
    repair_canvas_edges(h);
    smooth_open_sea(h);
    cv::Mat1b label, label_model;
    cv::resize(sketch.label, label_model, h.size(), 0, 0, cv::INTER_NEAREST);
    smooth_lagoon_floor(h, label_model);
    cv::resize(sketch.label, label, want, 0, 0, cv::INTER_NEAREST);
    // Passes and motu where the painting shows none, placed by the seed and
    // as many as the subsidence the network read (the age's, when given).
    const SeededReefDetails details = plan_reef_details(label_model, with_age(sketch, o.age_myr).subsidence,
                                                        o.world_size_m / h.cols, o.seed, o.variation);
    paint_seeded_motu(label, details, o.world_size_m / want.width);
    check_interrupt();  // between the network's answer and each amplification stage (reefgen/interrupt.hpp)
    const Rerolled r = reroll_for_amplify(h, o.world_size_m / h.cols, o.seed, o.variation, amplification_of(o));
    check_interrupt();
    h = amplify_heights(r.height_m, label, o.world_size_m, o.seed, r.params, true, sketch.ruggedness);
    check_interrupt();
    cut_seeded_passes(h, label, details, o.world_size_m / want.width, o.seed);
    cv::min(cv::max(h, range.lo_m), range.hi_m, h);
  } else if (want.width <= h.cols && want.height <= h.rows && h.size() != want) {
    cv::resize(h, h, want, 0, 0, cv::INTER_AREA);
  } else if (h.size() != want) {
    cv::resize(h, h, want, 0, 0, cv::INTER_LINEAR);
    cv::min(cv::max(h, range.lo_m), range.hi_m, h);  // interpolation stays in range; clamp anyway
  }
  return h;
}

}  // namespace

std::vector<cv::Mat1f> infer_heights(model::GeneratorFile& g, const std::vector<DecodedSketch>& sketches,
                                     const InferOptions& o, std::vector<cv::Mat1f>* before) {
  const std::vector<cv::Mat1f> answers = network_answers(g, sketches, o);
  std::vector<cv::Mat1f> heights;
  for (size_t i = 0; i < sketches.size(); ++i) heights.push_back(finish_answer(answers[i], sketches[i], o, g.range, before));
  return heights;
}

void check_variation_seeds(uint64_t first, int count) {
  if (count > 1 && first > UINT64_MAX - uint64_t(count - 1))
    throw Error("--seed " + std::to_string(first) + " with " + std::to_string(count) + " variations: the seeds pass " +
                std::to_string(UINT64_MAX) + "; use a seed ≤ " + std::to_string(UINT64_MAX - uint64_t(count - 1)));
}

std::vector<cv::Mat1f> infer_variations(model::GeneratorFile& g, const DecodedSketch& sketch, const InferOptions& o,
                                        int count, int threads, std::vector<cv::Mat1f>* before) {
  if (count < 1) throw Error("internal: infer_variations needs at least one");
  check_variation_seeds(o.seed, count);
  // One network pass (its answer does not depend on the seed but in
  // stochastic mode, where each seed needs its own masks).
  std::vector<cv::Mat1f> answers;
  for (int k = 0; k < (o.stochastic ? count : 1); ++k) {
    InferOptions ok = o;
    ok.seed = o.seed + uint64_t(k);
    answers.push_back(network_answers(g, {sketch}, ok)[0]);
  }
  std::vector<cv::Mat1f> heights(static_cast<size_t>(count));
  std::vector<std::vector<cv::Mat1f>> befores(static_cast<size_t>(count));
  parallel_for(size_t(count), threads, [&](size_t k) {
    InferOptions ok = o;
    ok.seed = o.seed + uint64_t(k);
    heights[k] = finish_answer(answers[o.stochastic ? k : 0].clone(), sketch, ok, g.range, before ? &befores[k] : nullptr);
  });
  if (before)
    for (auto& b : befores) before->push_back(std::move(b[0]));
  return heights;
}

}  // namespace reefgen::infer
