#include "reefgen/model/codec.hpp"

#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace reefgen::model {

torch::Tensor label_to_tensor(const cv::Mat3b& label_bgr) {
  cv::Mat3b rgb;
  cv::cvtColor(label_bgr, rgb, cv::COLOR_BGR2RGB);
  torch::Tensor t = torch::from_blob(rgb.data, {rgb.rows, rgb.cols, 3}, torch::kUInt8)  // {H,W,3}
                        .permute({2, 0, 1})                                         // {3,H,W}
                        .to(torch::kFloat32);
  return t.div_(127.5).sub_(1.0).contiguous();
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
