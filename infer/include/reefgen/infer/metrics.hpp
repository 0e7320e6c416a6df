#pragma once
// How good is a generator: height errors overall and per region, structure
// (SSIM), terrain character (slope distributions), coastlines, and the same
// under perturbed sketches (robustness, paper §7).
#include <array>
#include <cstdint>
#include <string>

#include <cmath>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reefgen/labels.hpp"

namespace reefgen::infer {

// Sums over pixels and pairs; finish() turns them into the reported figures.
struct MetricSums {
  double abs_sum = 0, sq_sum = 0;
  int64_t pixels = 0;
  std::array<double, 5> abs_region{}, sq_region{};
  std::array<int64_t, 5> px_region{};
  double ssim_sum = 0, slope_w1_sum = 0, coast_sum = 0, coast_truth_sum = 0;
  int64_t pairs = 0;
  void add(const MetricSums& o);
  nlohmann::json finish() const;  // MAE/RMSE in metres (overall, per region), mean SSIM, ...
};

// One pair. `label` = region ids of the (clean) sketch; heights in metres;
// `range` = the model's height range (SSIM data range); metres per pixel for slopes.
MetricSums pair_metrics(const cv::Mat1f& pred_m, const cv::Mat1f& truth_m, const cv::Mat1b& label, double lo_m,
                        double hi_m, double metres_per_px);

// SSIM (Wang et al. 2004; Gaussian window σ 1.5, 11x11, K1 0.01, K2 0.03) of
// two fields scaled to [0, 1] by [lo, hi].
double ssim(const cv::Mat1f& a, const cv::Mat1f& b, double lo, double hi);
// Earth mover's (Wasserstein-1) distance between the slope-angle distributions
// (degrees) of two fields of equal size.
double slope_distance_deg(const cv::Mat1f& a, const cv::Mat1f& b, double metres_per_px);

// Sketch perturbations for the robustness figures; pure in (image, seed).
enum class Perturbation { None, Blur, Jpeg50, HueJitter, BrushNoise };
const char* perturbation_name(Perturbation p);
cv::Mat3b perturb(const cv::Mat3b& sketch_bgr, Perturbation p, uint64_t seed);

}  // namespace reefgen::infer

namespace reefgen::infer {

// 2-px checkerboard amplitude of a height field: mean |h00 − h01 − h10 + h11|
// over every 2×2 window, metres. Transposed-convolution artefacts raise it;
// a clean procedural field is ≈ 0.1 m at 256².
double checkerboard_m(const cv::Mat1f& height_m);

// What a painted sketch's result should show, without ground truth
// (docs/MODEL.md): young (λ ≤ young_max) island and beach above the sea,
// young abyss deep, the reef crest just below the surface.
struct SketchChecks {
  int64_t land_px = 0, land_above_0 = 0;      // painted island + beach at λ ≤ young_max
  int64_t abyss_px = 0, abyss_below_0 = 0, abyss_below_20 = 0;  // painted abyss at λ ≤ young_max
  double reef_crest_m = std::nan("");         // 95th percentile of the reef pixels' heights (any λ)
  double checkerboard_m = 0;
};
SketchChecks sketch_checks(const cv::Mat1f& pred_m, const DecodedSketch& sketch, double young_max = 0.1);

}  // namespace reefgen::infer
