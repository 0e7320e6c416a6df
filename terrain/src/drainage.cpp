#include "reefgen/terrain/drainage.hpp"

#include <algorithm>
#include <cmath>
#include <type_traits>

#include "neighbours.hpp"

namespace reefgen::terrain {

namespace {
void size_for(const FlowGraph& g, std::vector<float>& area) {
  if (area.size() != g.receiver.size()) area.assign(g.receiver.size(), 0.f);
}
}  // namespace

void accumulate_single(const FlowGraph& g, const cv::Mat1b& role, float cell_area_m2, std::vector<float>& area,
                       const float* rain) {
  size_for(g, area);
  const uint8_t* rl = role.ptr<uint8_t>();
  for (const int i : g.stack) area[i] = rain ? cell_area_m2 * rain[i] : cell_area_m2;
  for (size_t k = g.stack.size(); k-- > 0;) {
    const int i = g.stack[k], r = g.receiver[i];
    if (rl[r] == kActive) area[r] += area[i];
  }
}

void accumulate_multiple(const FlowGraph& g, const cv::Mat1b& role, float cell_area_m2, double metres_per_px,
                         float exponent, std::vector<float>& area, const float* rain) {
  size_for(g, area);
  const uint8_t* rl = role.ptr<uint8_t>();
  const float* fz = g.surface.ptr<float>();
  const int W = g.surface.cols;
  const StepLengths len(metres_per_px);
  int offset[8];
  for (int d = 0; d < 8; ++d) offset[d] = kDy[d] * W + kDx[d];
  for (const int i : g.stack) area[i] = rain ? cell_area_m2 * rain[i] : cell_area_m2;
  // Stack cells are active, and active cells are never on the canvas edge
  // (sea_and_edge_roles makes it an outlet): every neighbour is at a flat
  // offset. The exponent's test is taken out of the cell loop (p = 1, the
  // default, shares by the slope itself).
  auto sweep = [&](auto unit_exponent) {
    for (size_t k = g.stack.size(); k-- > 0;) {
      const int i = g.stack[k];
      // Non-lower neighbours get a zero share; adding +0 leaves the sum's bits as they are.
      float w[8], sum = 0.f;
      if constexpr (decltype(unit_exponent)::value) {
        for (int d = 0; d < 8; ++d) {
          const float sl = (fz[i] - fz[i + offset[d]]) * len.inv[d];
          w[d] = sl > 0.f ? sl : 0.f;
          sum += w[d];
        }
      } else {
        // Shares of (slope / the steepest)^p: slope^p itself underflows where
        // land rises a few ulps a cell (slopes of ~1e-9 at the 0.1 m land
        // floor, 1e-36 at p = 4), and the area over that sum overflowed to
        // inf, then NaN heights.
        float steepest = 0.f;
        for (int d = 0; d < 8; ++d) {
          w[d] = (fz[i] - fz[i + offset[d]]) * len.inv[d];
          steepest = std::max(steepest, w[d]);
        }
        for (int d = 0; d < 8; ++d) {
          w[d] = w[d] > 0.f ? std::pow(w[d] / steepest, exponent) : 0.f;
          sum += w[d];
        }
      }
      // Slopes of a few ulps (an old island planed to its 0.1 m land floor)
      // sum to a denormal: the area over it overflows to inf, then NaN
      // heights. Such a cell is flat: it drains to its receiver.
      const float a = sum > 0.f ? area[i] / sum : 0.f;
      if (sum <= 0.f || !std::isfinite(a)) {
        const int r = g.receiver[i];
        if (rl[r] == kActive) area[r] += area[i];
        continue;
      }
      for (int d = 0; d < 8; ++d)
        if (w[d] > 0.f) {
          const int j = i + offset[d];
          if (rl[j] == kActive) area[j] += a * w[d];
        }
    }
  };
  if (exponent == 1.f) sweep(std::true_type{});
  else sweep(std::false_type{});
}

}  // namespace reefgen::terrain
