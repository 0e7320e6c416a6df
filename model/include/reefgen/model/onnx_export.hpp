#pragma once
// The generator as an ONNX graph, for runtimes that do not read LibTorch
// archives (Unity Sentis, Unreal NNE, ONNX Runtime, OpenCV's dnn;
// docs/ENGINES.md "The model in other runtimes"). LibTorch 1.13 has no C++
// exporter, so the ModelProto is written here, field by field, in protobuf's
// wire format: opset 13 (ONNX IR 7), one fixed input side.
//
// The graph is UNetGenerator::forward as `reefgen infer` runs it (dropout
// off) followed by the height decode, so it answers metres:
//   input  "label"    float32 {1,3,S,S}: the label map's RGB scaled to [-1,1]
//   output "height_m" float32 {1,1,S,S}: lo + (y + 1)/2 · (hi − lo), y = tanh(G)
// Normalisation in the default mode (statistics of the sample itself, what
// pix2pix and reefgen run at test time) is InstanceNormalization — for one
// sample, BatchNorm with batch statistics is exactly that, with BatchNorm's
// γ and β as its scale and bias; with running statistics it is
// BatchNormalization with the stored means and variances.
#include <filesystem>
#include <string>

#include "reefgen/model/codec.hpp"
#include "reefgen/model/networks.hpp"

namespace reefgen::model {

inline constexpr int64_t kOnnxOpset = 13;      // Resize with an empty roi; every op used is in it
inline constexpr int64_t kOnnxIrVersion = 7;   // the IR that opset 13 ships with

struct OnnxExportOptions {
  int size_px = 256;           // the input side; a multiple of 2^depth; [32, 4096]
  bool running_stats = false;  // BatchNorm from its running averages (infer --running-stats)
};

// The serialised ModelProto. Throws reefgen::Error for a side the net cannot take.
std::string generator_onnx(UNetGeneratorImpl& g, const HeightRange& range, const OnnxExportOptions& options);

// Written atomically (temp + rename).
void write_generator_onnx(const std::filesystem::path& path, UNetGeneratorImpl& g, const HeightRange& range,
                          const OnnxExportOptions& options);

}  // namespace reefgen::model
