#include "reefgen/terrain/ocean_floor.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "reefgen/error.hpp"

namespace reefgen::terrain {

namespace {

// Cells below the knee connected to the border through cells below it (4-neighbours).
cv::Mat1b open_ocean(const cv::Mat1f& h) {
  const int W = h.cols, H = h.rows;
  cv::Mat1b seen(h.size(), uint8_t(0));
  std::vector<cv::Point> stack;
  auto push = [&](int x, int y) {
    if (x < 0 || y < 0 || x >= W || y >= H || seen(y, x) || !(h(y, x) < kFlankKneeM)) return;
    seen(y, x) = 1;
    stack.push_back({x, y});
  };
  for (int x = 0; x < W; ++x) push(x, 0), push(x, H - 1);
  for (int y = 0; y < H; ++y) push(0, y), push(W - 1, y);
  while (!stack.empty()) {
    const cv::Point p = stack.back();
    stack.pop_back();
    push(p.x + 1, p.y), push(p.x - 1, p.y), push(p.x, p.y + 1), push(p.x, p.y - 1);
  }
  return seen;
}

}  // namespace

void deepen_flank(cv::Mat1f& h, double ocean_floor_m) {
  if (!std::isfinite(ocean_floor_m) || ocean_floor_m < kDeepestOceanFloorM || ocean_floor_m > kShallowestOceanFloorM)
    throw Error("ocean floor " + std::to_string(ocean_floor_m) + " m is out of range; expected [-11000, -60] m (above -60 m the flank is not stretched)");
  if (h.empty()) return;
  const cv::Mat1b ocean = open_ocean(h);
  if (cv::countNonZero(ocean) == 0) return;
  double lowest = 0;
  cv::minMaxLoc(h, &lowest, nullptr, nullptr, nullptr, ocean);
  if (ocean_floor_m >= lowest) return;
  lowest = std::min(lowest, double(kFlankKneeM - kMinFlankSpanM));
  const double scale = (ocean_floor_m - kFlankKneeM) / (lowest - kFlankKneeM);
  for (int y = 0; y < h.rows; ++y) {
    float* r = h.ptr<float>(y);
    const uint8_t* o = ocean.ptr<uint8_t>(y);
    for (int x = 0; x < h.cols; ++x)
      if (o[x]) r[x] = float(kFlankKneeM + (double(r[x]) - kFlankKneeM) * scale);
  }
}

}  // namespace reefgen::terrain
