#include "reefgen/terrain/eroders.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace reefgen::terrain {

namespace {
// Smallest σ (cells) whose blur is worth a pass over the land.
constexpr double kMinBlurSigmaPx = 0.15;
}  // namespace

void erode_stream_power(cv::Mat1f& height_m, const cv::Mat1f& erodibility_k, const FlowGraph& g,
                        const std::vector<float>& area, double dt_yr, double m_area) {
  float* z = height_m.ptr<float>();
  const float* k = erodibility_k.ptr<float>();
  const float m = static_cast<float>(m_area), dt = static_cast<float>(dt_yr);
  for (const int i : g.stack) {
    const float F = k[i] * dt * std::exp(m * std::log(area[i])) * g.inv_length[i];
    z[i] = (z[i] + F * z[g.receiver[i]]) / (1.f + F);
  }
}

double hillslope_sigma_px(double diffusivity, double dt_yr, double metres_per_px) {
  return std::sqrt(2.0 * diffusivity * dt_yr) / metres_per_px;
}

int hillslope_margin_px(double sigma_px) { return static_cast<int>(std::ceil(3 * sigma_px)) + 1; }

void diffuse_hillslope(cv::Mat1f& height_m, const cv::Mat1b& role, const cv::Rect& roi, double sigma_px) {
  if (!(sigma_px > kMinBlurSigmaPx)) return;
  cv::Mat1f blurred;
  cv::GaussianBlur(height_m(roi), blurred, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  for (int y = roi.y; y < roi.y + roi.height; ++y) {
    const float* b = blurred.ptr<float>(y - roi.y);
    float* z = height_m.ptr<float>(y);
    const uint8_t* rl = role.ptr<uint8_t>(y);
    for (int x = roi.x; x < roi.x + roi.width; ++x)
      if (rl[x] == kActive) z[x] = std::max(b[x - roi.x], 0.f);
  }
}

}  // namespace reefgen::terrain
