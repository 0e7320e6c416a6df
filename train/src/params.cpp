#include "reefgen/train/params.hpp"

#include "reefgen/json_read.hpp"

#include <cmath>
#include <set>

#include "reefgen/io.hpp"

namespace reefgen::train {

using nlohmann::json;

// One list of fields: serialisation, parsing and the unknown-key check all
// come from it, so a new field cannot be forgotten in one of them.
#define REEFGEN_TRAIN_FIELDS(X)                                                                        \
  X(seed) X(ngf) X(ndf) X(depth) X(d_layers) X(norm) X(upsample) X(dropout) X(lr) X(beta1) X(beta2) X(lambda_l1) \
  X(batch_size) X(epochs) X(epochs_decay) X(jitter) X(jitter_scale) X(flip) X(log_every) X(val_every) \
  X(val_samples) X(val_max_pairs) X(checkpoint_every) X(loader_threads) X(prefetch) X(threads)         \
  X(deterministic) X(engine) X(precision)

void to_json(json& j, const TrainParams& p) {
  j = json::object();
#define X(f) j[#f] = p.f;
  REEFGEN_TRAIN_FIELDS(X)
#undef X
}

TrainParams train_params_from_json(const json& j, const std::string& origin) {
  if (!j.is_object()) throw Error(origin + ": a training config must be a JSON object");
  static const std::set<std::string> known = {
#define X(f) #f,
      REEFGEN_TRAIN_FIELDS(X)
#undef X
  };
  for (const auto& [k, v] : j.items())
    if (!known.count(k)) throw Error(origin + ": unknown key '" + k + "' (see configs/train/paper.json for the keys)");
  TrainParams p;
  try {
#define X(f) \
  if (j.contains(#f)) read_json_value(j.at(#f), p.f, origin + ": " #f);
    REEFGEN_TRAIN_FIELDS(X)
#undef X
  } catch (const json::exception& e) {
    throw Error(origin + ": wrong type of value (" + std::string(e.what()) + ")");
  }
  validate(p, origin);
  return p;
}

void validate(const TrainParams& p, const std::string& origin) {
  auto range = [&](const char* name, double v, double lo, double hi, bool lo_open = false, bool hi_open = false) {
    const bool ok = std::isfinite(v) && (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
    if (!ok)
      throw Error(origin + ": " + name + " = " + std::to_string(v) + " is out of range " + (lo_open ? "(" : "[") +
                  std::to_string(lo) + ", " + std::to_string(hi) + (hi_open ? ")" : "]"));
  };
  range("ngf", p.ngf, 1, 1024);
  range("ndf", p.ndf, 1, 1024);
  range("depth", p.depth, 5, 12);
  range("d_layers", p.d_layers, 1, 8);
  if (p.norm != "batch" && p.norm != "instance" && p.norm != "none")
    throw Error(origin + ": norm = '" + p.norm + "'; use batch, instance or none");
  if (p.upsample != "transpose" && p.upsample != "nearest" && p.upsample != "bilinear")
    throw Error(origin + ": upsample = '" + p.upsample + "'; use transpose, nearest or bilinear");
  range("dropout", p.dropout, 0, 1, false, true);
  range("lr", p.lr, 0, 1, true);
  range("beta1", p.beta1, 0, 1, false, true);
  range("beta2", p.beta2, 0, 1, false, true);
  range("lambda_l1", p.lambda_l1, 0, 1e4);
  range("batch_size", p.batch_size, 1, 64);
  range("epochs", p.epochs, 0, 1e4);
  range("epochs_decay", p.epochs_decay, 0, 1e4);
  if (p.epochs + p.epochs_decay <= 0) throw Error(origin + ": epochs + epochs_decay must be > 0");
  range("jitter_scale", p.jitter_scale, 1, 2);
  range("log_every", p.log_every, 1, 1e9);
  range("val_every", p.val_every, 1, 1e9);
  range("val_samples", p.val_samples, 1, 64);
  range("val_max_pairs", p.val_max_pairs, 1, 1e9);
  range("checkpoint_every", p.checkpoint_every, 1, 1e9);
  range("loader_threads", p.loader_threads, 1, 64);
  range("prefetch", p.prefetch, 1, 1024);
  range("threads", p.threads, 0, 1024);
  if (p.engine != "onednn" && p.engine != "torch")
    throw Error(origin + ": engine = '" + p.engine + "'; use onednn or torch");
  if (p.precision != "fp32" && p.precision != "bf16" && p.precision != "auto")
    throw Error(origin + ": precision = '" + p.precision + "'; use fp32, bf16 or auto");
  if (p.precision == "bf16" && p.engine != "onednn")
    throw Error(origin + ": precision = 'bf16' needs engine = 'onednn' (LibTorch's bf16 convolutions are no faster here)");
}

std::string resolved_precision(const TrainParams& p) {
  if (p.precision != "auto") return p.precision;
  return p.engine == "onednn" && model::cpu_has_native_bf16() ? "bf16" : "fp32";
}

Pix2PixOptions pix2pix_options(const TrainParams& p) {
  Pix2PixOptions o;
  o.g.ngf = p.ngf;
  o.g.depth = p.depth;
  o.g.norm = model::norm_from_string(p.norm);
  o.g.upsample = model::upsample_from_string(p.upsample);
  o.g.dropout = p.dropout;
  o.d.ndf = p.ndf;
  o.d.n_layers = p.d_layers;
  o.d.norm = o.g.norm;
  o.lr = p.lr;
  o.beta1 = p.beta1;
  o.beta2 = p.beta2;
  o.lambda_l1 = p.lambda_l1;
  o.conv.engine = p.engine == "torch" ? model::ConvEngine::Torch : model::ConvEngine::OneDnn;
  o.conv.precision = resolved_precision(p) == "bf16" ? model::ConvPrecision::Bf16 : model::ConvPrecision::Fp32;
  return o;
}

double lr_at(const TrainParams& p, int64_t step, int64_t steps_constant, int64_t steps_decay) {
  if (step < steps_constant) return p.lr;
  // pix2pix's linear rule, per step: 1 - k/(n_decay + 1), k = 1 at the first decayed step.
  const double k = double(step - steps_constant + 1);
  return p.lr * std::max(0.0, 1.0 - k / double(steps_decay + 1));
}

}  // namespace reefgen::train
