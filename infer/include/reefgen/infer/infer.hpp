#pragma once
// Sketch -> height field with an exported generator (paper §7).
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "reefgen/labels.hpp"
#include "reefgen/model/generator_file.hpp"

namespace reefgen::infer {

// Number format of the generator's arithmetic. bf16 runs oneDNN's bfloat16
// convolutions (fast where the CPU has avx512_bf16 or AMX-bf16), with the
// weights rounded to bf16 and float32 accumulation; heights stay within 1 m of
// float32 (tested). auto = bf16 where the CPU has AMX-bf16, else fp32 (on
// avx512_bf16 alone it measured no faster).
enum class Precision { Auto, Fp32, Bf16 };
Precision precision_from_string(const std::string& s);  // "auto" | "fp32" | "bf16"
const char* to_string(Precision p);
bool cpu_has_native_bf16();  // avx512_bf16 or amx_bf16, read with cpuid
bool cpu_has_amx_bf16();
Precision resolve(Precision p);  // auto -> fp32 or bf16 on this CPU
// For one generator: auto -> fp32 for transposed-convolution generators;
// explicit bf16 on one of those throws std::invalid_argument.
Precision resolve(Precision p, const model::GeneratorFile& g);

struct InferOptions {
  Precision precision = Precision::Fp32;  // the CLI's default is auto
  bool stochastic = false;     // dropout on (pix2pix's noise source): varied outputs per --seed
  bool running_stats = false;  // BatchNorm running statistics instead of pix2pix's test-time batch statistics
  uint64_t seed = 0;           // dropout masks when stochastic
};

// The decoded sketch re-encoded in the canonical palette at the model's size:
// regions by nearest neighbour (never blended), subsidence bilinear.
cv::Mat3b canonical_sketch(const DecodedSketch& sketch, int size_px);

// Heights in metres at the sketch's own size (bilinear back from the model's
// side when the sketch is another size), always inside the model's range.
// Each output depends on its own sketch only: batch-statistics mode runs one
// sketch per forward (a batch would share BatchNorm statistics), running
// statistics mode batches 8 at a time.
std::vector<cv::Mat1f> infer_heights(model::GeneratorFile& g, const std::vector<DecodedSketch>& sketches,
                                     const InferOptions& o);

}  // namespace reefgen::infer
