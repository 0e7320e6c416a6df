#include "reefgen/wide_blur.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace reefgen {

cv::Mat1f wide_gaussian_blur(const cv::Mat1f& m, double sigma_px) {
  cv::Mat1f out;
  if (sigma_px <= kWideBlurWorkSigmaPx) {
    cv::GaussianBlur(m, out, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
    return out;
  }
  const double shrink = kWideBlurWorkSigmaPx / sigma_px;
  const cv::Size work(std::max(16, int(std::ceil(m.cols * shrink))), std::max(16, int(std::ceil(m.rows * shrink))));
  cv::resize(m, out, work, 0, 0, cv::INTER_AREA);
  const double sx = sigma_px * work.width / m.cols, sy = sigma_px * work.height / m.rows;
  cv::GaussianBlur(out, out, cv::Size(0, 0), sx, sy, cv::BORDER_REPLICATE);
  cv::resize(out, out, m.size(), 0, 0, cv::INTER_LINEAR);
  return out;
}

}  // namespace reefgen
