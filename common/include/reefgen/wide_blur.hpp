#pragma once
// A Gaussian blur whose σ grows with the canvas (region blends, style blends):
// at 8192² a σ of 1 % of the side is an 82-px σ, a ~500-tap kernel per pixel
// and pass, tens of seconds on one core. Above kWideBlurWorkSigmaPx it is
// computed where σ spans that many cells (area-averaged down, blurred,
// read back bilinearly): the blurred field is smooth over σ, so the read back
// stays within ~1 % of the field's range (tests/test_erosion.cpp) at a cost
// that no longer grows with σ. At or below it, cv::GaussianBlur itself:
// the same bytes as before for every canvas where σ is small.
#include <opencv2/core.hpp>

namespace reefgen {

inline constexpr double kWideBlurWorkSigmaPx = 16;  // px on the working grid; 6σ ≈ 100 taps

// m blurred with a Gaussian of sigma_px (replicated border), on a coarser
// grid where σ is above work_sigma_px. A smaller work σ is cheaper and
// coarser: the bilinear read back of cells h = σ/w apart misses by about
// h²/8 · max|f''| ≤ h²/8 · 0.24/σ² of the range = 0.03/w² (0.2 % at w = 4).
cv::Mat1f wide_gaussian_blur(const cv::Mat1f& m, double sigma_px, double work_sigma_px = kWideBlurWorkSigmaPx);

}  // namespace reefgen
