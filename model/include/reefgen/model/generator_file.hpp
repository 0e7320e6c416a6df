#pragma once
// The exported generator: what `reefgen infer` loads. G's weights (buffers
// included) with the options that rebuild it and the height range of its
// output, in one LibTorch archive (zip). Much smaller than a training
// checkpoint, which also holds D and both optimizers.
#include <filesystem>
#include <string>

#include <map>
#include <memory>

#include "reefgen/model/codec.hpp"
#include "reefgen/model/fast_unet.hpp"
#include "reefgen/model/networks.hpp"

namespace reefgen::model {

inline constexpr const char* kGeneratorFormat = "reefgen-generator";
// Version 2 adds the weights' storage type (float32 or float16, always loaded
// as float32) and a SHA-256 of the stored weights, checked on load: a file
// with flipped bytes is refused instead of producing wrong terrains. Version 1
// files (float32, no checksum) still load.
inline constexpr int64_t kGeneratorFormatVersion = 2;

enum class WeightStorage { Float32, Float16 };

struct GeneratorFile {
  UNetGenerator g{nullptr};
  UNetGenerator g_bf16{nullptr};  // a bfloat16 copy, made on first use by LibTorch bf16 inference
  // oneDNN engines built on first use, one per (batch, side, precision, mode).
  std::map<std::string, std::shared_ptr<FastUNet>> fast;
  HeightRange range;
  int size_px = 256;       // the side it was trained at
  int64_t train_step = 0;  // steps done when exported
  std::string reefgen_version;
  std::string weights_sha256;  // empty for version-1 files
  WeightStorage storage = WeightStorage::Float32;
};

// Written atomically (temp + rename); throws std::runtime_error naming the path.
void save_generator(const std::filesystem::path& path, UNetGenerator& g, const HeightRange& range, int size_px,
                    int64_t train_step, WeightStorage storage = WeightStorage::Float32);

// SHA-256 over G's parameters and buffers as stored (name, dtype, shape and
// raw bytes, in the module's fixed order).
std::string weights_sha256(torch::nn::Module& g);
// Throws std::runtime_error naming the path and the fix for a missing,
// truncated, foreign or incompatible file.
GeneratorFile load_generator(const std::filesystem::path& path);

}  // namespace reefgen::model
