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
                        const std::vector<float>& area, double dt_yr, double m_area, double channel_head_m2) {
  float* z = height_m.ptr<float>();
  const float* k = erodibility_k.ptr<float>();
  const float m = static_cast<float>(m_area), dt = static_cast<float>(dt_yr);
  const float head = static_cast<float>(channel_head_m2);
  for (const int i : g.stack) {
    if (area[i] < head) continue;
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

// Cells either side of a channel that creep is kept off (with the channel).
constexpr int kChannelBankPx = 2;

void creep_between_channels(cv::Mat1f& height_m, const cv::Mat1b& role, const cv::Rect& roi,
                            const std::vector<float>& area_m2, float channel_area_m2, double sigma_px) {
  if (!(sigma_px > kMinBlurSigmaPx) || !(channel_area_m2 > 0) || area_m2.size() != height_m.total()) return;
  // The share that creeps, itself blurred like the ground: a channel one
  // cell wide beside fully creeping ground left a slot with serrated banks.
  cv::Mat1f open(roi.size(), 0.f);
  for (int y = roi.y; y < roi.y + roi.height; ++y) {
    const float* a = area_m2.data() + size_t(y) * size_t(height_m.cols);
    const uint8_t* rl = role.ptr<uint8_t>(y);
    float* o = open.ptr<float>(y - roi.y);
    for (int x = roi.x; x < roi.x + roi.width; ++x) {
      const float f = std::max(0.f, 1.f - a[x] / channel_area_m2);
      o[x - roi.x] = rl[x] == kActive ? f * f : 0.f;
    }
  }
  // Widened by kChannelBankPx first, so the channel itself keeps its floor
  // (a share blurred from 0 on one cell is ~0.7 there at σ = 1.5).
  cv::erode(open, open, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * kChannelBankPx + 1, 2 * kChannelBankPx + 1)),
            cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  cv::Mat1f blurred;
  cv::GaussianBlur(height_m(roi), blurred, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  cv::GaussianBlur(open, open, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  for (int y = roi.y; y < roi.y + roi.height; ++y) {
    const float* b = blurred.ptr<float>(y - roi.y);
    const float* o = open.ptr<float>(y - roi.y);
    float* z = height_m.ptr<float>(y);
    const uint8_t* rl = role.ptr<uint8_t>(y);
    for (int x = roi.x; x < roi.x + roi.width; ++x)
      if (rl[x] == kActive) z[x] = std::max(z[x] + o[x - roi.x] * (b[x - roi.x] - z[x]), 0.f);
  }
}

}  // namespace reefgen::terrain
