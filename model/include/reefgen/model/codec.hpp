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

// What a generator reads (docs/MODEL.md "The age channel"): the label map's
// three channels, and for a generator trained with the maturity channel a
// fourth plane holding the erosion maturity the answer is to have.
inline constexpr int kLabelChannels = 3;
inline constexpr int kLabelAndMaturityChannels = 4;
// The maturity as the fourth plane holds it: ln(m) / ln(kMaxMaturity), so the
// unit maturity (the erosion as configured, every model before the channel)
// is 0 and the range [kMinMaturity, kMaxMaturity] about [-1, 1]; clamped.
float maturity_code(double maturity);
// The label tensor {3,H,W} with the maturity plane appended: {4,H,W}.
torch::Tensor with_maturity(const torch::Tensor& label, double maturity);
// The input of a generator of in_channels (kLabelChannels or
// kLabelAndMaturityChannels; the maturity is read only by the latter).
torch::Tensor network_input(const cv::Mat3b& label_bgr, int in_channels, double maturity);  // {in,H,W}
torch::Tensor height_to_tensor(const cv::Mat1f& height_m, const HeightRange& r);  // {1,H,W} in [-1,1]
// {1,H,W} or {H,W} normalised -> metres, clamped into [lo, hi]: output heights never leave the range.
cv::Mat1f tensor_to_height(const torch::Tensor& t, const HeightRange& r);

}  // namespace reefgen::model
