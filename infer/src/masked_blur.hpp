#pragma once
// A Gaussian mean over the cells of a mask alone (normalised convolution):
// what the clean-ups of a model answer smooth towards, so that the cells left
// out (land beside water, water beside land) do not pull the mean. Internal
// to the infer library.
#include <limits>

#include <opencv2/imgproc.hpp>

#include "reefgen/wide_blur.hpp"

namespace reefgen::infer {

// sum = G_σ ∗ (h·m), weight = G_σ ∗ m (m = 1 on the mask's cells, 0 off it);
// the mean is sum / weight where weight is not ~0. Replicated borders. Where
// σ passes work_sigma_px both blurs run on a coarser grid (wide_blur.hpp).
struct MaskedBlur {
  cv::Mat1f sum, weight;
};

inline MaskedBlur masked_blur(const cv::Mat1f& h, const cv::Mat1b& mask, double sigma,
                              double work_sigma_px = std::numeric_limits<double>::infinity()) {
  cv::Mat1f inside = cv::Mat1f::zeros(h.size());
  h.copyTo(inside, mask);
  const cv::Mat1f on = cv::Mat1f(mask) / 255.f;
  MaskedBlur b;
  b.sum = wide_gaussian_blur(inside, sigma, work_sigma_px);
  b.weight = wide_gaussian_blur(on, sigma, work_sigma_px);
  return b;
}

}  // namespace reefgen::infer
