#pragma once
// A Gaussian mean over the cells of a mask alone (normalised convolution):
// what the clean-ups of a model answer smooth towards, so that the cells left
// out (land beside water, water beside land) do not pull the mean. Internal
// to the infer library.
#include <opencv2/imgproc.hpp>

namespace reefgen::infer {

// sum = G_σ ∗ (h·m), weight = G_σ ∗ m (m = 1 on the mask's cells, 0 off it);
// the mean is sum / weight where weight is not ~0. Replicated borders.
struct MaskedBlur {
  cv::Mat1f sum, weight;
};

inline MaskedBlur masked_blur(const cv::Mat1f& h, const cv::Mat1b& mask, double sigma) {
  cv::Mat1f inside = cv::Mat1f::zeros(h.size());
  h.copyTo(inside, mask);
  const cv::Mat1f on = cv::Mat1f(mask) / 255.f;
  MaskedBlur b;
  cv::GaussianBlur(inside, b.sum, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
  cv::GaussianBlur(on, b.weight, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
  return b;
}

}  // namespace reefgen::infer
