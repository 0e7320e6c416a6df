#pragma once
// Images <-> network tensors. Labels: 8-bit RGB (not BGR) scaled to [-1, 1],
// as pix2pix feeds its A images. Heights: metres mapped linearly from the
// model's fixed range [lo, hi] onto [-1, 1] (docs/DESIGN.md §5), and back.
#include <opencv2/core.hpp>
#include <torch/torch.h>

#include "reefgen/constants.hpp"

namespace reefgen::model {

struct HeightRange {
  double lo_m = kAbyssFloorM;      // maps to -1; the dataset's floor
  double hi_m = kHeightCeilingM;  // maps to +1; bounds every generated height
};

torch::Tensor label_to_tensor(const cv::Mat3b& label_bgr);                     // {3,H,W} RGB in [-1,1]
torch::Tensor height_to_tensor(const cv::Mat1f& height_m, const HeightRange& r);  // {1,H,W} in [-1,1]
// {1,H,W} or {H,W} normalised -> metres, clamped into [lo, hi]: output heights never leave the range.
cv::Mat1f tensor_to_height(const torch::Tensor& t, const HeightRange& r);

}  // namespace reefgen::model
