#pragma once
// Small helpers over a painted region map (labels.hpp) shared by the painted
// reef's finish and its seeded details. Internal to the infer library.
#include <cstdint>

#include <opencv2/imgproc.hpp>

#include "reefgen/labels.hpp"

namespace reefgen::infer {

// Painted land: island or beach.
inline bool landlike(uint8_t r) { return r == kIsland || r == kBeach; }

// Distance (px) from each cell to the nearest cell where `zero` holds; `cap` where none does.
inline cv::Mat1f distance_to(const cv::Mat1b& zero, float cap) {
  cv::Mat1f d;
  if (cv::countNonZero(zero) == 0) return cv::Mat1f(zero.size(), cap);
  cv::distanceTransform(cv::Mat1b(zero == 0), d, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  return cv::min(d, cap);
}

}  // namespace reefgen::infer
