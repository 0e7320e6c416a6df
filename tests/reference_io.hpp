#pragma once
// Reads scripts/reference/pix2pix_ref.py's output: reference.json (names,
// dtypes, shapes, offsets) + reference.bin (little-endian raw tensors).
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <nlohmann/json.hpp>
#include <torch/torch.h>

namespace reefgen::test {

struct Reference {
  nlohmann::json meta;
  std::map<std::string, torch::Tensor> tensors;
  const torch::Tensor& at(const std::string& name) const {
    auto it = tensors.find(name);
    if (it == tensors.end()) throw std::runtime_error("reference has no tensor " + name);
    return it->second;
  }
};

inline Reference load_reference(const std::filesystem::path& dir) {
  Reference r;
  std::ifstream js(dir / "reference.json");
  const nlohmann::json j = nlohmann::json::parse(js);
  r.meta = j.at("meta");
  std::ifstream bin(dir / "reference.bin", std::ios::binary);
  for (const auto& e : j.at("tensors")) {
    std::vector<int64_t> shape = e.at("shape").get<std::vector<int64_t>>();
    const bool f32 = e.at("dtype") == "f32";
    torch::Tensor t = torch::empty(shape, f32 ? torch::kFloat32 : torch::kInt64);
    bin.seekg(e.at("offset").get<std::streamoff>());
    bin.read(static_cast<char*>(t.data_ptr()), std::streamsize(t.numel() * t.element_size()));
    if (!bin) throw std::runtime_error("reference.bin truncated at " + e.at("name").get<std::string>());
    r.tensors[e.at("name")] = t;
  }
  return r;
}

// Copies every parameter and buffer of `net` from reference tensors named
// prefix + C++ name; returns how many were copied. Throws on a missing name
// or a shape mismatch: the two architectures must be the same tensor for tensor.
inline size_t copy_weights(torch::nn::Module& net, const Reference& ref, const std::string& prefix) {
  torch::NoGradGuard no_grad;
  size_t n = 0;
  auto copy = [&](const std::string& name, torch::Tensor& dst) {
    const torch::Tensor& src = ref.at(prefix + name);
    if (src.sizes() != dst.sizes())
      throw std::runtime_error(prefix + name + ": shape " + c10::str(src.sizes()) + " vs " + c10::str(dst.sizes()));
    dst.copy_(src);
    ++n;
  };
  for (auto& p : net.named_parameters()) copy(p.key(), p.value());
  for (auto& b : net.named_buffers()) copy(b.key(), b.value());
  return n;
}

}  // namespace reefgen::test
