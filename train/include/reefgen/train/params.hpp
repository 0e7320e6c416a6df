#pragma once
// Training configuration (paper §6, docs/DESIGN.md §5). configs/train/*.json are this
// struct serialised; command-line flags override them.
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "reefgen/params_json.hpp"
#include "reefgen/model/codec.hpp"
#include "reefgen/train/pix2pix.hpp"

namespace reefgen::train {

struct TrainParams {
  uint64_t seed = 1;            // weights init, data order, jitter, dropout
  // Networks
  int ngf = 64;                 // G filters of the outermost layer, [1, 1024]
  int ndf = 64;                 // D filters of the first layer, [1, 1024]
  int depth = 8;                // U-Net down-samplings; the side must be a multiple of 2^depth, [5, 12]
  int d_layers = 3;             // PatchGAN layers: 3 = 70x70 patches, [1, 8]
  std::string norm = "batch";   // batch | instance | none
  std::string upsample = "transpose";  // G's decoder: transpose (pix2pix) | nearest | bilinear (resize-convolution)
  double dropout = 0.5;         // in G's three innermost decoder blocks, [0, 1)
  bool maturity_channel = false;  // G and D also read each pair's erosion maturity as a 4th input plane (docs/MODEL.md "The age channel")
  // Optimisation
  double lr = 2e-4;             // Adam learning rate, (0, 1]
  double beta1 = 0.5;           // Adam β1, [0, 1)
  double beta2 = 0.999;         // Adam β2, [0, 1)
  double lambda_l1 = 100;       // L1 weight in G's loss, [0, 1e4]
  double l1_shore_weight = 0;   // extra L1 weight on cells whose truth is near sea level (pix2pix.hpp L1Weighting); 0 = plain L1, [0, 100]
  double l1_shore_m = 3;        // half-width of that band, metres, (0, 100]
  double lambda_slope = 0;      // weight of the slope L1 in G's loss (pix2pix.hpp slope_l1); 0 = pix2pix's loss, [0, 1e5]
  double lambda_rise = 0;       // weight of the uphill-slope L1 on land in G's loss (pix2pix.hpp rise_l1); 0 = none, [0, 1e5]
  double lambda_logit = 0;      // weight of the bound on G's saturated logits (pix2pix.hpp logit_excess); 0 = none, [0, 1e5]
  int d_crop_px = 0;            // D sees the pairs cropped by a random 0..d_crop_px cells per side (pix2pix.hpp); 0 = whole, [0, 64]
  int batch_size = 1;           // pix2pix: 1, [1, 64]
  double epochs = 1;            // epochs at constant lr, [0, 1e4]
  double epochs_decay = 1;      // then epochs of linear decay to 0, [0, 1e4]; both 0 is refused
  // Jitter (pix2pix's resize-and-crop + flip), identical on label and height
  bool jitter = true;           // off: pairs used as stored
  double jitter_scale = 286.0 / 256.0;  // resize factor before cropping back, [1, 2]
  bool flip = true;             // random horizontal flip
  // Run
  int log_every = 100;          // steps per log.csv row (means over the window), [1, 1e9]
  int val_every = 1000;         // steps per validation grid PNG, [1, 1e9]
  int val_samples = 4;          // rows of the validation grid, [1, 64]
  int val_max_pairs = 200;      // val pairs for the per-epoch MAE, [1, 1e9]
  int checkpoint_every = 1000;  // steps per checkpoint, [1, 1e9]
  int loader_threads = 2;       // background data loading threads, [1, 64]
  int prefetch = 8;             // batches loaded ahead, [1, 1024]
  int threads = 0;              // LibTorch threads; 0 = all cores
  bool deterministic = true;    // LibTorch deterministic algorithms (resume = uninterrupted, bit for bit)
  std::string engine = "onednn";  // convolutions: onednn (model/dnnl_conv.hpp, faster) | torch (LibTorch's)
  std::string precision = "fp32"; // convolutions: fp32 | bf16 (onednn only; fp32 master weights) | auto (bf16 where the CPU has avx512_bf16/AMX)
};

// The one field list (common/params_json.hpp); validate() adds the rules
// between fields.
template <class F>
void fields(TrainParams& p, F&& f) {
  f("seed", p.seed);
  f("ngf", p.ngf, Range{1, 1024});
  f("ndf", p.ndf, Range{1, 1024});
  f("depth", p.depth, Range{5, 12});
  f("d_layers", p.d_layers, Range{1, 8});
  f("norm", p.norm, OneOf{{"batch", "instance", "none"}});
  f("upsample", p.upsample, OneOf{{"transpose", "nearest", "bilinear"}});
  f("dropout", p.dropout, Range{0, 1, false, true});
  f("maturity_channel", p.maturity_channel);
  f("lr", p.lr, Range{0, 1, true, false});
  f("beta1", p.beta1, Range{0, 1, false, true});
  f("beta2", p.beta2, Range{0, 1, false, true});
  f("lambda_l1", p.lambda_l1, Range{0, 1e4});
  f("l1_shore_weight", p.l1_shore_weight, Range{0, 100});
  f("l1_shore_m", p.l1_shore_m, Range{0, 100, true, false});
  f("lambda_slope", p.lambda_slope, Range{0, 1e5});
  f("lambda_rise", p.lambda_rise, Range{0, 1e5});
  f("lambda_logit", p.lambda_logit, Range{0, 1e5});
  f("d_crop_px", p.d_crop_px, Range{0, 64});
  f("batch_size", p.batch_size, Range{1, 64});
  f("epochs", p.epochs, Range{0, 1e4});
  f("epochs_decay", p.epochs_decay, Range{0, 1e4});
  f("jitter", p.jitter);
  f("jitter_scale", p.jitter_scale, Range{1, 2});
  f("flip", p.flip);
  f("log_every", p.log_every, Range{1, 1e9});
  f("val_every", p.val_every, Range{1, 1e9});
  f("val_samples", p.val_samples, Range{1, 64});
  f("val_max_pairs", p.val_max_pairs, Range{1, 1e9});
  f("checkpoint_every", p.checkpoint_every, Range{1, 1e9});
  f("loader_threads", p.loader_threads, Range{1, 64});
  f("prefetch", p.prefetch, Range{1, 1024});
  f("threads", p.threads, Range{0, 1024});
  f("deterministic", p.deterministic);
  f("engine", p.engine, OneOf{{"onednn", "torch"}});
  f("precision", p.precision, OneOf{{"fp32", "bf16", "auto"}});
}
void to_json(nlohmann::json& j, const TrainParams& p);
// Every key optional; unknown keys and out-of-range values throw reefgen::Error naming them and `origin`.
TrainParams train_params_from_json(const nlohmann::json& j, const std::string& origin);
void validate(const TrainParams& p, const std::string& origin);

// The params of a run, as `reefgen train` resolves them: the config file if
// given; else, when resuming, the config saved in RUN/run.json; else the
// built-in defaults. `overrides` (keys of TrainParams, e.g. from flags) win
// over all of them. Errors name where the values came from.
TrainParams train_params_for_run(const std::string& config_path, const fs::path& run_dir, bool resume,
                                 const nlohmann::json& overrides);

// G's input channels: the label map's, and the maturity plane with maturity_channel.
int in_channels_of(const TrainParams& p);

// `range` (the dataset's height normalisation) turns l1_shore_m into normalised units.
Pix2PixOptions pix2pix_options(const TrainParams& p, const model::HeightRange& range = {});
// "auto" decided on this CPU: "bf16" with avx512_bf16 or AMX-bf16 (and the oneDNN engine), else "fp32".
std::string resolved_precision(const TrainParams& p);

// Learning rate before step s (0-based) of `total` = steps_constant + steps_decay:
// lr for the first steps_constant, then linear decay reaching 0 after the last step.
double lr_at(const TrainParams& p, int64_t step, int64_t steps_constant, int64_t steps_decay);

}  // namespace reefgen::train
