#pragma once
// The exported generator: what `reefgen infer` loads. G's weights (buffers
// included) with the options that rebuild it and the height range of its
// output, in one LibTorch archive (zip). Much smaller than a training
// checkpoint, which also holds D and both optimizers.
#include <filesystem>
#include <string>

#include "reefgen/model/codec.hpp"
#include "reefgen/model/networks.hpp"

namespace reefgen::model {

inline constexpr const char* kGeneratorFormat = "reefgen-generator";
inline constexpr int64_t kGeneratorFormatVersion = 1;

struct GeneratorFile {
  UNetGenerator g{nullptr};
  HeightRange range;
  int size_px = 256;       // the side it was trained at
  int64_t train_step = 0;  // steps done when exported
  std::string reefgen_version;
};

// Written atomically (temp + rename); throws std::runtime_error naming the path.
void save_generator(const std::filesystem::path& path, UNetGenerator& g, const HeightRange& range, int size_px,
                    int64_t train_step);
// Throws std::runtime_error naming the path and the fix for a missing,
// truncated, foreign or incompatible file.
GeneratorFile load_generator(const std::filesystem::path& path);

}  // namespace reefgen::model
