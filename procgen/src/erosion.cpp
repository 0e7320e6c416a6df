#include "reefgen/procgen/erosion.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

#include "reefgen/io.hpp"
#include "reefgen/procgen/noise.hpp"

namespace reefgen::procgen {

using nlohmann::json;

#define REEFGEN_EROSION_FIELDS(X)                                                                          \
  X(thermal_iterations, 0, 1000) X(talus_slope, 1e-6, 10) X(thermal_rate, 0, 0.5)                         \
  X(hydraulic_iterations, 0, 1000) X(rain_m, 0, 100) X(capacity, 0, 100) X(solubility, 0, 1)              \
  X(deposition, 0, 1) X(evaporation, 0, 1) X(final_thermal_iterations, 0, 1000)                          \
  X(final_talus_slope, 1e-6, 10) X(final_thermal_rate, 0, 0.5) X(noise_amplitude, 0, 1)

void to_json(json& j, const ErosionParams& p) {
  j = json::object();
#define X(f, lo, hi) j[#f] = p.f;
  REEFGEN_EROSION_FIELDS(X)
#undef X
}

ErosionParams erosion_params_from_json(const json& j, const std::string& origin) {
  if (!j.is_object()) throw Error(origin + ": erosion must be a JSON object");
  static const std::set<std::string> known = {
#define X(f, lo, hi) #f,
      REEFGEN_EROSION_FIELDS(X)
#undef X
  };
  for (const auto& [k, v] : j.items())
    if (!known.count(k)) throw Error(origin + ": unknown key \"erosion." + k + "\"");
  ErosionParams p;
#define X(f, lo, hi)                                                                                    \
  if (j.contains(#f)) {                                                                                 \
    const auto& v = j.at(#f);                                                                           \
    if (!v.is_number()) throw Error(origin + ": erosion." #f " must be a number");                    \
    const double d = v.get<double>();                                                                   \
    using T = decltype(p.f);                                                                            \
    if (!(d >= lo && d <= hi) || (std::is_integral_v<T> && d != std::floor(d)))                        \
      throw Error(origin + ": erosion." #f " = " + v.dump() + " is out of range; expected " +          \
                  (std::is_integral_v<T> ? "an integer in [" : "[") + std::to_string(lo) + ", " +      \
                  std::to_string(hi) + "]");                                                            \
    p.f = static_cast<T>(d);                                                                            \
  }
  REEFGEN_EROSION_FIELDS(X)
#undef X
  return p;
}

namespace {

constexpr int kDx[4] = {1, -1, 0, 0}, kDy[4] = {0, 0, 1, -1};

// Thermal erosion: where the drop to a 4-neighbour exceeds the talus, a share
// of the excess slides down, scaled by (1 − resistance). Double-buffered
// (every cell reads the previous iteration), so the result does not depend on
// the sweep order.
void thermal(cv::Mat1f& h, const cv::Mat1f& soft, double talus_m, double rate, int iterations) {
  const int H = h.rows, W = h.cols;
  cv::Mat1f delta(H, W);
  for (int it = 0; it < iterations; ++it) {
    delta.setTo(0.f);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const float c = h(y, x);
        for (int k = 0; k < 2; ++k) {  // each pair once: right and down neighbours
          const int nx = x + (k == 0), ny = y + (k == 1);
          if (nx >= W || ny >= H) continue;
          const float n = h(ny, nx), d = c - n;
          const float excess = std::abs(d) - static_cast<float>(talus_m);
          if (excess <= 0) continue;
          // The upper cell's softness decides how much of it moves.
          const bool down = d > 0;
          const float s = down ? soft(y, x) : soft(ny, nx);
          const float m = static_cast<float>(rate) * 0.5f * excess * s;
          if (down) { delta(y, x) -= m; delta(ny, nx) += m; }
          else { delta(y, x) += m; delta(ny, nx) -= m; }
        }
      }
    h += delta;
  }
}

// Hydraulic erosion on a water/sediment grid: rain on land, water runs to the
// lowest 4-neighbour of the water surface, carrying sediment up to a capacity
// proportional to water × slope; below capacity it erodes the (soft) ground,
// above it deposits. In the sea the water vanishes and drops its load.
void hydraulic(cv::Mat1f& h, const cv::Mat1f& soft, double dx_m, const ErosionParams& p) {
  const int H = h.rows, W = h.cols;
  cv::Mat1f w(H, W, 0.f), s(H, W, 0.f), w2(H, W), s2(H, W);
  for (int it = 0; it < p.hydraulic_iterations; ++it) {
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (h(y, x) > 0) w(y, x) += static_cast<float>(p.rain_m);
    w.copyTo(w2);
    s.copyTo(s2);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const float wc = w(y, x);
        if (wc <= 0) continue;
        const float surf = h(y, x) + wc;
        int best = -1;
        float best_surf = surf;
        for (int k = 0; k < 4; ++k) {
          const int nx = x + kDx[k], ny = y + kDy[k];
          if (nx < 0 || ny < 0 || nx >= W || ny >= H) continue;
          const float o = h(ny, nx) + w(ny, nx);
          if (o < best_surf) { best_surf = o; best = k; }
        }
        if (best < 0) continue;
        const int nx = x + kDx[best], ny = y + kDy[best];
        const float moved = std::min(wc, 0.5f * (surf - best_surf));
        const float share = moved / wc;
        const float sed = s(y, x) * share;
        w2(y, x) -= moved;
        w2(ny, nx) += moved;
        s2(y, x) -= sed;
        s2(ny, nx) += sed;
        // Erode or deposit where the water leaves, by the ground slope.
        const float slope = std::max(0.f, (h(y, x) - h(ny, nx)) / static_cast<float>(dx_m));
        const float cap = static_cast<float>(p.capacity) * moved * slope;
        if (sed < cap) {
          const float e = std::min(static_cast<float>(p.solubility) * (cap - sed) * soft(y, x),
                                   std::max(0.f, h(y, x) - h(ny, nx)));
          h(y, x) -= e;
          s2(ny, nx) += e;
        } else {
          const float d = static_cast<float>(p.deposition) * (sed - cap);
          h(y, x) += d;
          s2(ny, nx) -= d;
        }
      }
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        float& wc = w2(y, x);
        float& sc = s2(y, x);
        if (h(y, x) <= 0) {  // the sea: the load settles, the water is gone
          h(y, x) += std::max(0.f, sc);
          wc = 0;
          sc = 0;
          continue;
        }
        wc *= static_cast<float>(1.0 - p.evaporation);
        if (sc < 0) sc = 0;
      }
    std::swap(w, w2);
    std::swap(s, s2);
  }
  h += s;  // what is still suspended settles where it is
}

}  // namespace

void erode(cv::Mat1f& height_m, const cv::Mat1f& resistance, double metres_per_px, uint64_t seed,
           const ErosionParams& p) {
  if (height_m.empty() || height_m.size() != resistance.size())
    throw Error("erode: height and resistance must be non-empty and of the same size");
  if (!(metres_per_px > 0)) throw Error("erode: metres_per_px must be > 0");
  const int H = height_m.rows, W = height_m.cols;
  // Softness = 1 − resistance, modulated by low-frequency noise (about four
  // features across the canvas) so hard and soft bands are not perfect rings.
  const GradientNoise2 noise(seed);
  cv::Mat1f soft(H, W);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const float n = noise.fbm(4.f * x / W + 0.37f, 4.f * y / H + 0.71f, 2);
      const float r = std::clamp(resistance(y, x) * (1.f + static_cast<float>(p.noise_amplitude) * n), 0.f, 1.f);
      soft(y, x) = 1.f - r;
    }
  thermal(height_m, soft, p.talus_slope * metres_per_px, p.thermal_rate, p.thermal_iterations);
  hydraulic(height_m, soft, metres_per_px, p);
  thermal(height_m, soft, p.final_talus_slope * metres_per_px, p.final_thermal_rate, p.final_thermal_iterations);
}

}  // namespace reefgen::procgen
