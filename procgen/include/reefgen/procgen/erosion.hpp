#pragma once
// The generator's erosion (docs/EROSION.md): the island rendered at its
// output size, eroded on the base grid by terrain/erosion.hpp and refined
// back to that size with the render's own finer detail.
#include <cstdint>

#include <opencv2/core.hpp>

#include "reefgen/terrain/erosion.hpp"

namespace reefgen::procgen {

// The generator's erosion: the island rendered at its output size (heights
// before coral, resistance ρ(x̃) per pixel), eroded on the base grid and
// refined back to that size with the render's own finer detail.
cv::Mat1f erode_island(const cv::Mat1f& height_m, const cv::Mat1f& resistance, double world_size_m, uint64_t seed,
                       const terrain::ErosionParams& p);

}  // namespace reefgen::procgen
