#include "reefgen/infer/infer.hpp"

#include <opencv2/imgproc.hpp>

#include "reefgen/rng.hpp"

namespace reefgen::infer {

cv::Mat3b canonical_sketch(const DecodedSketch& s, int size_px) {
  cv::Mat1b label = s.label;
  cv::Mat1f sub = s.subsidence;
  if (label.rows != size_px || label.cols != size_px) {
    cv::resize(s.label, label, {size_px, size_px}, 0, 0, cv::INTER_NEAREST);
    cv::resize(s.subsidence, sub, {size_px, size_px}, 0, 0, cv::INTER_LINEAR);
  }
  return encode_labels(label, sub);
}

std::vector<cv::Mat1f> infer_heights(model::GeneratorFile& g, const std::vector<DecodedSketch>& sketches,
                                     const InferOptions& o) {
  c10::InferenceMode inference;  // no autograd bookkeeping at all (cheaper than NoGradGuard)
  // pix2pix runs G in train mode at test time: BatchNorm normalises with the
  // sample's own statistics. With batch statistics a batch would mix samples,
  // so that mode runs one sketch per forward; running statistics batch freely.
  g.g->train(!o.running_stats);
  g.g->set_dropout_enabled(o.stochastic);
  std::vector<torch::Tensor> inputs;
  for (const auto& s : sketches) inputs.push_back(model::label_to_tensor(canonical_sketch(s, g.size_px)));
  std::vector<torch::Tensor> outs;
  // Stochastic mode runs one sketch per forward with the masks of --seed, so a
  // sketch gives the same island alone or in a folder, in any position.
  const size_t batch = o.running_stats && !o.stochastic ? 8 : 1;
  for (size_t i = 0; i < inputs.size(); i += batch) {
    const size_t n = std::min(batch, inputs.size() - i);
    if (o.stochastic) torch::manual_seed(derive_seed(o.seed, 0, "infer-dropout"));
    const torch::Tensor x = torch::stack(std::vector<torch::Tensor>(inputs.begin() + long(i), inputs.begin() + long(i + n)));
    const torch::Tensor y = g.g->forward(x);  // {n,1,S,S}
    for (size_t k = 0; k < n; ++k) outs.push_back(y[long(k)]);
  }
  std::vector<cv::Mat1f> heights;
  for (size_t i = 0; i < sketches.size(); ++i) {
    cv::Mat1f h = model::tensor_to_height(outs[i], g.range);
    const cv::Size want = sketches[i].label.size();
    if (h.size() != want) {
      cv::resize(h, h, want, 0, 0, cv::INTER_LINEAR);
      cv::min(cv::max(h, g.range.lo_m), g.range.hi_m, h);  // interpolation stays in range; clamp anyway
    }
    heights.push_back(h);
  }
  return heights;
}

}  // namespace reefgen::infer
