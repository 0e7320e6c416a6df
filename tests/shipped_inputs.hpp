#pragma once
// The shipped generator as users run it and the painted test sketches as its
// inputs: shared by the engine tests (test_fast_unet.cpp) and the ONNX export
// tests (test_onnx.cpp).
#include <filesystem>
#include <string>
#include <vector>

#include "reefgen/labels.hpp"
#include "reefgen/model/codec.hpp"
#include "reefgen/model/generator_file.hpp"

namespace reefgen::test {

// The shipped generator as users run it (pix2pix's test-time mode, no
// dropout), and the painted test sketches at the model's 256²: each one's
// file name, decoded labels and network input {1,3,256,256}.
inline model::GeneratorFile shipped_generator() {
  model::GeneratorFile gf =
      model::load_generator(std::filesystem::path(REEFGEN_SOURCE_DIR) / "models" / "reef-256.pt");
  gf.g->train(true);
  gf.g->set_dropout_enabled(false);
  return gf;
}
struct PaintedInput {
  std::string name;
  DecodedSketch sketch;
  torch::Tensor x;
};
inline std::vector<PaintedInput> painted_inputs_256() {
  std::vector<PaintedInput> out;
  const auto dir = std::filesystem::path(REEFGEN_SOURCE_DIR) / "tests" / "data" / "painted";
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    DecodedSketch s = read_sketch(e.path());
    if (s.label.rows != 256 || s.label.cols != 256) continue;
    torch::Tensor x = model::label_to_tensor(encode_labels(s.label, s.subsidence)).unsqueeze(0);
    out.push_back({e.path().filename().string(), std::move(s), std::move(x)});
  }
  return out;
}

}  // namespace reefgen::test
