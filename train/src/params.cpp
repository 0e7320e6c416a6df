#include "reefgen/train/params.hpp"

#include "reefgen/cpu.hpp"

#include "reefgen/json_read.hpp"


#include "reefgen/files.hpp"

namespace reefgen::train {

using nlohmann::json;

void to_json(json& j, const TrainParams& p) { j = params_json(p); }

TrainParams train_params_from_json(const json& j, const std::string& origin) {
  TrainParams p = params_from_json<TrainParams>(j, origin, "configs/train/paper.json for the keys");
  validate(p, origin);
  return p;
}

TrainParams train_params_for_run(const std::string& config_path, const fs::path& run_dir, bool resume,
                                 const json& overrides) {
  json j = json::object();
  std::string origin = "built-in training defaults";
  const fs::path run_json = run_dir / "run.json";
  if (!config_path.empty()) {
    j = read_json(config_path);
    origin = config_path;
  } else if (resume && fs::exists(run_json)) {
    const json saved = read_json(run_json);
    if (!saved.contains("config") || !saved["config"].is_object())
      throw Error(run_json.string() + ": no \"config\" object; give --config FILE to resume this run");
    j = saved["config"];
    origin = run_json.string();
  }
  if (!overrides.is_object()) throw Error("training overrides must be a JSON object");
  for (const auto& [k, v] : overrides.items()) j[k] = v;
  if (!overrides.empty()) origin += " with the command-line flags";
  return train_params_from_json(j, origin);
}

void validate(const TrainParams& p, const std::string& origin) {
  check_params(p, origin, "docs/TRAINING.md");
  if (p.epochs + p.epochs_decay <= 0) throw Error(origin + ": epochs + epochs_decay must be > 0");
  if (p.precision == "bf16" && p.engine != "onednn")
    throw Error(origin + ": precision = 'bf16' needs engine = 'onednn' (LibTorch's bf16 convolutions are no faster here)");
}

std::string resolved_precision(const TrainParams& p) {
  // Configs stay valid on every CPU (validate() does not look at it); the
  // run that would need bf16 convolutions is refused here, before any file.
  if (p.precision == "bf16" && !model::bf16_convolution_available())
    throw Error("precision = 'bf16' but oneDNN cannot build bf16 convolutions on this CPU (" + cpu_summary() +
                "): use --precision fp32 or auto");
  if (p.precision != "auto") return p.precision;
  return p.engine == "onednn" && model::cpu_has_native_bf16() ? "bf16" : "fp32";
}

int in_channels_of(const TrainParams& p) {
  return p.maturity_channel ? model::kLabelAndMaturityChannels : model::kLabelChannels;
}

Pix2PixOptions pix2pix_options(const TrainParams& p, const model::HeightRange& range) {
  Pix2PixOptions o;
  o.g.ngf = p.ngf;
  o.g.depth = p.depth;
  o.g.norm = model::norm_from_string(p.norm);
  o.g.upsample = model::upsample_from_string(p.upsample);
  o.g.dropout = p.dropout;
  o.g.in_channels = in_channels_of(p);
  o.d.in_channels = o.g.in_channels + o.g.out_channels;
  o.d.ndf = p.ndf;
  o.d.n_layers = p.d_layers;
  o.d.norm = o.g.norm;
  o.lr = p.lr;
  o.beta1 = p.beta1;
  o.beta2 = p.beta2;
  o.lambda_l1 = p.lambda_l1;
  o.lambda_slope = p.lambda_slope;
  o.lambda_rise = p.lambda_rise;
  o.lambda_logit = p.lambda_logit;
  o.d_crop = p.d_crop_px;
  // Heights are normalised as 2 (h - lo) / (hi - lo) - 1 (model/codec.hpp).
  const double per_m = 2.0 / (range.hi_m - range.lo_m);
  o.l1.extra = p.l1_shore_weight;
  o.l1.sea = -range.lo_m * per_m - 1;
  o.l1.band = p.l1_shore_m * per_m;
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
