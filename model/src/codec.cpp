#include "reefgen/model/codec.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

#include "reefgen/age.hpp"

namespace reefgen::model {

torch::Tensor label_to_tensor(const cv::Mat3b& label_bgr) {
  cv::Mat3b rgb;
  cv::cvtColor(label_bgr, rgb, cv::COLOR_BGR2RGB);
  torch::Tensor t = torch::from_blob(rgb.data, {rgb.rows, rgb.cols, 3}, torch::kUInt8)  // {H,W,3}
                        .permute({2, 0, 1})                                         // {3,H,W}
                        .to(torch::kFloat32);
  return t.div_(127.5).sub_(1.0).contiguous();
}

float maturity_code(double maturity) {
  const double m = std::clamp(maturity, kMinMaturity, kMaxMaturity);
  return static_cast<float>(std::clamp(std::log(m) / std::log(kMaxMaturity), -1.0, 1.0));
}

torch::Tensor with_maturity(const torch::Tensor& label, double maturity) {
  if (label.dim() != 3 || label.size(0) != kLabelChannels)
    throw std::invalid_argument("with_maturity: expected a label tensor {3,H,W}, got " + c10::str(label.sizes()));
  const torch::Tensor plane = torch::full({1, label.size(1), label.size(2)}, maturity_code(maturity));  // {1,H,W}
  return torch::cat({label, plane}, 0);  // {4,H,W}
}

torch::Tensor network_input(const cv::Mat3b& label_bgr, int in_channels, double maturity) {
  if (in_channels == kLabelChannels) return label_to_tensor(label_bgr);
  if (in_channels == kLabelAndMaturityChannels) return with_maturity(label_to_tensor(label_bgr), maturity);
  throw std::invalid_argument("network_input: a generator reads " + std::to_string(kLabelChannels) + " or " +
                              std::to_string(kLabelAndMaturityChannels) + " channels, not " + std::to_string(in_channels));
}

torch::Tensor height_to_tensor(const cv::Mat1f& height_m, const HeightRange& r) {
  cv::Mat1f h = height_m.isContinuous() ? height_m : height_m.clone();
  torch::Tensor t = torch::from_blob(h.data, {1, h.rows, h.cols}, torch::kFloat32).clone();  // {1,H,W}
  return t.sub_(r.lo_m).mul_(2.0 / (r.hi_m - r.lo_m)).sub_(1.0);
}

cv::Mat1f tensor_to_height(const torch::Tensor& t, const HeightRange& r) {
  torch::Tensor x = t.detach().to(torch::kCPU, torch::kFloat32);
  if (x.dim() == 3) x = x.squeeze(0);
  if (x.dim() != 2) throw std::invalid_argument("tensor_to_height: expected {1,H,W} or {H,W}, got " + c10::str(t.sizes()));
  x = x.clamp(-1.0, 1.0).add(1.0).mul((r.hi_m - r.lo_m) / 2.0).add(r.lo_m).clamp(r.lo_m, r.hi_m).contiguous();
  cv::Mat1f out(int(x.size(0)), int(x.size(1)));
  std::memcpy(out.data, x.data_ptr<float>(), sizeof(float) * x.numel());
  return out;
}

}  // namespace reefgen::model
