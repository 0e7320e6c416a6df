#pragma once
// The model's answer finished (docs/EROSION.md, "The model's own side"):
// ponds of sea inside land raised, pits drained, and above the model's side
// the answer amplified with the generator's refinement. LibTorch-free.
#include <cstdint>

#include <opencv2/core.hpp>

#include "reefgen/terrain/erosion.hpp"

namespace reefgen::infer {

// Amplification of a coarse height field (a 256² model answer) to size×size
// (infer --size N): the coarse field's land is roughened (amplify_roughness)
// and eroded once on its own grid (pits
// filled by sediment, valleys the model smoothed re-carved), then refined
// level by level as the generator refines its own islands, with fractal
// detail noise (amplitude ∝ cell size) standing in for the render's finer
// detail. Only land moves; the sea is the coarse answer, bicubic, except
// the small ponds of sea enclosed by land (amplify_pond_max_m2), which
// become land. label: the sketch's regions at
// size×size.
cv::Mat1f amplify_heights(const cv::Mat1f& coarse_m, const cv::Mat1b& label, double world_size_m, uint64_t seed,
                          const terrain::ErosionParams& p = {});

}  // namespace reefgen::infer
