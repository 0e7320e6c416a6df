#pragma once
// Sketch -> height field with an exported generator (paper §7).
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "reefgen/age.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/model/dnnl_conv.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/infer/amplify_params.hpp"

namespace reefgen::infer {

// Number format of the generator's arithmetic. bf16 runs oneDNN's bfloat16
// convolutions (fast where the CPU has avx512_bf16 or AMX-bf16), with the
// weights rounded to bf16 and float32 accumulation; heights stay within 1 m of
// float32 (tested). auto = bf16 where the CPU has avx512_bf16 or AMX-bf16 and
// the oneDNN engine runs (1.6–1.7× its fp32 there), else fp32.
enum class Precision { Auto, Fp32, Bf16 };
Precision precision_from_string(const std::string& s);  // "auto" | "fp32" | "bf16"
const char* to_string(Precision p);
using model::cpu_has_native_bf16;  // avx512_bf16 or amx_bf16, read with cpuid (model/dnnl_conv.hpp)
using model::cpu_has_amx_bf16;
Precision resolve(Precision p);  // auto -> fp32 or bf16 on this CPU

// What runs the generator. onednn: reefgen's engine (model/fast_unet.hpp),
// 1.5× LibTorch in fp32 and 2.5× in bf16 on the shipped model; torch:
// LibTorch's own forward (the reference). auto = onednn, except in
// --stochastic mode (dropout masks come from LibTorch's generator).
enum class Engine { Auto, OneDnn, Torch };
Engine engine_from_string(const std::string& s);  // "auto" | "onednn" | "torch"
const char* to_string(Engine e);

struct InferOptions {
  Precision precision = Precision::Fp32;  // the CLI's default too: the same heights on every CPU
  Engine engine = Engine::Auto;
  bool stochastic = false;     // dropout on (pix2pix's noise source): varied outputs per --seed
  bool running_stats = false;  // BatchNorm running statistics instead of pix2pix's test-time batch statistics
  uint64_t seed = 0;           // the island's re-roll (variation), the amplification's noise; dropout masks when stochastic
  // How far the seed re-rolls the island, [0, 1] (infer/variation.hpp): the
  // summit and ridges moved inside the painted land, then eroded anew at
  // every size (the model's side too). 0: the network's answer, cleaned up
  // (what `reefgen eval` measures).
  double variation = 1.0;
  // The island's age in My (reefgen/age.hpp; kNotSet = the painting's own
  // brightness): its subsidence replaces the painted one everywhere, and its
  // erosion maturity sets the amplification's (infer::matured). maturity
  // alone (or over the age's) sets the latter only.
  double age_myr = kNotSet;
  double maturity = kNotSet;
  int size_px = 0;             // output side, [0, 8192]; 0 = the sketch's own size
  double ocean_floor_m = 0;    // m: the open ocean's flank continued towards it after amplification (terrain/ocean_floor.hpp); 0 = off
  double world_size_m = kCanvasWorldSizeM;  // canvas width in metres (the amplification's erosion works in metres)
  // amplify_heights at every square size: the model's own side gets
  // its clean-up (ponds raised, erosion on its grid, pits breached), larger
  // sides also erosion + detail at each finer level. false (`--raw`): the
  // network's answer, only resized.
  bool amplify = true;
  AmplifyParams amplification;  // the amplification's erosion and shaping (docs/EROSION.md); defaults = the shipped tuning
};

// The engine and precision these options run with this generator on this
// CPU. Throws reefgen::Error for bf16 with the torch engine on a
// transposed-convolution generator (LibTorch's bf16 refuses its 1×1 layer)
// and for the onednn engine in stochastic mode.
Engine resolve_engine(const InferOptions& o);
Precision resolve(const InferOptions& o, const model::GeneratorFile& g);

// The decoded sketch re-encoded in the canonical palette at the model's size:
// regions by nearest neighbour (never blended), subsidence bilinear.
cv::Mat3b canonical_sketch(const DecodedSketch& sketch, int size_px);

// The sketch as the network reads it under an age (kNotSet: as painted):
// the age's subsidence replaces the painted brightness everywhere.
DecodedSketch with_age(const DecodedSketch& s, double age_myr);
// The amplification's params for the options' age or maturity (matured).
AmplifyParams amplification_of(const InferOptions& o);

// The maturity a generator with the maturity channel is asked for
// (model/codec.hpp): the options' maturity, else their age's, else 1 (the
// erosion the training data had before the channel).
double network_maturity(const InferOptions& o);

// One forward of the generator on x {n,in,S,S} (S a multiple of 2^depth; the
// oneDNN engine up to 4096) → {n,1,S,S} in [-1, 1], by engine and precision
// as resolved; the caller sets g's train/dropout modes (infer_heights does).
// The oneDNN engine's plan is built once per (n, S, precision, mode).
torch::Tensor forward_generator(model::GeneratorFile& g, const torch::Tensor& x, Engine engine, Precision precision,
                                bool running_stats);

// Heights in metres at o.size_px (default: the sketch's own size). Above the
// model's side, a square output is amplified (amplify_heights:
// erosion that carves valleys at each finer level, never a bilinear stretch);
// below it, area-averaged. Always inside the model's range.
// Each output depends on its own sketch only: batch-statistics mode runs one
// sketch per forward (a batch would share BatchNorm statistics), running
// statistics mode batches 8 at a time.
// before (optional): each network answer at the output size before its
// clean-up and amplification (bicubic), for the wear and deposit layers.
std::vector<cv::Mat1f> infer_heights(model::GeneratorFile& g, const std::vector<DecodedSketch>& sketches,
                                     const InferOptions& o, std::vector<cv::Mat1f>* before = nullptr);

// Throws reefgen::Error when seeds first … first + count − 1 pass 2^64 − 1
// (they wrapped to seed 0 and wrote PREFIX.seed0.*).
void check_variation_seeds(uint64_t first, int count);

// `count` islands of one sketch, seeds o.seed, o.seed + 1, …: each as
// infer_heights gives it with that seed (same bytes), the network run once
// (once per seed when stochastic) and the re-rolls and amplifications on
// `threads` threads.
std::vector<cv::Mat1f> infer_variations(model::GeneratorFile& g, const DecodedSketch& sketch, const InferOptions& o,
                                        int count, int threads, std::vector<cv::Mat1f>* before = nullptr);

}  // namespace reefgen::infer
