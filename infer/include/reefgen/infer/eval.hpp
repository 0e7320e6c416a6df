#pragma once
// How good is a generator: height errors overall and per region, structure
// (SSIM), terrain character (slope distributions), coastlines, and the same
// under perturbed sketches (robustness, paper §7).
#include <array>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

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
