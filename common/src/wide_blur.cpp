#include "reefgen/wide_blur.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace reefgen {

cv::Mat1f wide_gaussian_blur(const cv::Mat1f& m, double sigma_px, double work_sigma_px) {
  cv::Mat1f out;
  if (sigma_px <= work_sigma_px) {
    cv::GaussianBlur(m, out, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
    return out;
  }
  const double shrink = work_sigma_px / sigma_px;
  const cv::Size work(std::max(16, int(std::ceil(m.cols * shrink))), std::max(16, int(std::ceil(m.rows * shrink))));
  cv::resize(m, out, work, 0, 0, cv::INTER_AREA);
  // The area average down (a box of a work cell, variance 1/12 cell²) and
  // the bilinear read back (a tent, 1/6 cell²) blur too: the work grid's
  // Gaussian is narrowed by their variance, so the three together are σ.
  const auto work_sigma = [&](int full, int cells) {
    const double cell_px = double(full) / cells;
    return std::sqrt(std::max(0.25, sigma_px * sigma_px - cell_px * cell_px / 4)) / cell_px;
  };
  const double sx = work_sigma(m.cols, work.width), sy = work_sigma(m.rows, work.height);
  cv::GaussianBlur(out, out, cv::Size(0, 0), sx, sy, cv::BORDER_REPLICATE);
  cv::resize(out, out, m.size(), 0, 0, cv::INTER_LINEAR);
  return out;
}

}  // namespace reefgen
