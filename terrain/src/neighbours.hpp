#pragma once
// The 8 neighbours of a grid cell, in the order every router and the
// accumulation visit them (4 axial, then 4 diagonal), and 1 / the length of
// each step. Internal to terrain/.
#include <cmath>

namespace reefgen::terrain {

constexpr int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1}, kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};

// 1 / length of each of the 8 steps, 1/m.
struct StepLengths {
  float axial, diagonal, inv[8];
  explicit StepLengths(double metres_per_px)
      : axial(static_cast<float>(1.0 / metres_per_px)),
        diagonal(static_cast<float>(1.0 / (metres_per_px * std::sqrt(2.0)))),
        inv{axial, axial, axial, axial, diagonal, diagonal, diagonal, diagonal} {}
};

}  // namespace reefgen::terrain
