#include "reefgen/terrain/dissection.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/terrain/drainage.hpp"
#include "reefgen/terrain/flow.hpp"
#include "reefgen/terrain/realism.hpp"

namespace reefgen::terrain {

DissectionStats dissection_stats(const cv::Mat1f& h, double metres_per_px) {
  if (h.empty()) throw Error("dissection: the height field is empty");
  if (!(metres_per_px > 0) || !std::isfinite(metres_per_px))
    throw Error("dissection: metres per pixel must be a positive number");
  if (!cv::checkRange(h)) throw Error("dissection: the height field holds NaN or infinite values");
  const cv::Mat1f hc = h.isContinuous() ? h : h.clone();
  DissectionStats st;
  double peak = 0, sum = 0;
  for (int y = 0; y < hc.rows; ++y)
    for (int x = 0; x < hc.cols; ++x)
      if (hc(y, x) > 0) ++st.land_cells, peak = std::max(peak, double(hc(y, x))), sum += hc(y, x);
  if (st.land_cells == 0) return st;
  st.land_km2 = double(st.land_cells) * metres_per_px * metres_per_px * 1e-6;
  int64_t high = 0;
  for (int y = 0; y < hc.rows; ++y)
    for (int x = 0; x < hc.cols; ++x) high += hc(y, x) > 0.5 * peak;
  st.land_above_half_peak = double(high) / double(st.land_cells);
  st.hypsometric_integral = sum / double(st.land_cells) / peak;

  // Channels: steepest descent on the filled surface, drainage area summed.
  const cv::Mat1b role = sea_and_edge_roles(hc);
  FlowGraph graph;
  route_flood(hc, role, metres_per_px, graph);
  std::vector<float> area_m2;
  accumulate_single(graph, role, float(metres_per_px * metres_per_px), area_m2);
  // Valleys: convergent on the smoothed heights (realism_stats' test).
  cv::Mat1f smooth, curv, grad;
  const double sigma_px = kValleySmoothingM / metres_per_px;
  cv::GaussianBlur(hc, smooth, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  plan_curvature(smooth, metres_per_px, curv, grad);
  // Each channel cell adds the length of its step to its receiver.
  double length_m = 0;
  for (const int i : graph.stack) {
    const int y = i / hc.cols, x = i % hc.cols;
    if (hc(y, x) <= 0 || area_m2[i] < kDrainageChannelAreaM2 || !(curv(y, x) < kValleyCurvature)) continue;
    if (graph.inv_length[i] > 0) length_m += 1.0 / graph.inv_length[i];
  }
  st.drainage_density_per_km = length_m * 1e-3 / st.land_km2;
  return st;
}

}  // namespace reefgen::terrain
