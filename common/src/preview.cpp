#include "reefgen/preview.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace reefgen {

namespace {

struct Stop { double t; double r, g, b; };

cv::Vec3d ramp(const Stop* stops, int n, double t) {
  t = std::clamp(t, 0.0, 1.0);
  for (int i = 1; i < n; ++i)
    if (t <= stops[i].t) {
      const double u = (t - stops[i - 1].t) / (stops[i].t - stops[i - 1].t);
      return {stops[i - 1].r + u * (stops[i].r - stops[i - 1].r), stops[i - 1].g + u * (stops[i].g - stops[i - 1].g),
              stops[i - 1].b + u * (stops[i].b - stops[i - 1].b)};
    }
  return {stops[n - 1].r, stops[n - 1].g, stops[n - 1].b};
}

// Water by depth fraction (0 = surface, 1 = sea floor): shallow reef flats
// read turquoise, the lagoon mid-blue, the abyss navy.
constexpr Stop kWater[] = {{0.00, 170, 235, 235}, {0.03, 90, 210, 220}, {0.2, 40, 140, 200}, {0.5, 25, 80, 160}, {1.0, 10, 25, 80}};
// Land by height fraction of the top: beach sand, lowland green, rock, snow-ish peak.
constexpr Stop kLand[] = {{0.00, 235, 220, 165}, {0.02, 200, 205, 130}, {0.08, 95, 160, 75},
                          {0.45, 110, 120, 60},  {0.75, 130, 100, 75}, {1.0, 245, 245, 240}};

}  // namespace

cv::Mat3b render_preview(const cv::Mat1f& h, const PreviewOptions& opt) {
  const int rows = h.rows, cols = h.cols;
  double top = opt.land_top_m;
  if (top <= 0) {
    double mx;
    cv::minMaxLoc(h, nullptr, &mx);
    top = std::max(50.0, mx);
  }
  const double floor_m = std::min(-1.0, opt.sea_floor_m);
  const double mpp = opt.metres_per_px > 0 ? opt.metres_per_px : 2000.0 / cols;
  const double az = opt.sun_azimuth_deg * M_PI / 180, el = opt.sun_elevation_deg * M_PI / 180;
  // Light direction in image space (x right, y down), z up.
  const double lx = std::cos(el) * std::cos(az), ly = -std::cos(el) * std::sin(az), lz = std::sin(el);
  cv::Mat3b out(rows, cols);
  auto at = [&](int y, int x) { return h(std::clamp(y, 0, rows - 1), std::clamp(x, 0, cols - 1)); };
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x) {
      const double v = h(y, x);
      const double dzdx = (at(y, x + 1) - at(y, x - 1)) / (2 * mpp);
      const double dzdy = (at(y + 1, x) - at(y - 1, x)) / (2 * mpp);
      // Normal of z = f(x, y) is (-fx, -fy, 1)/|.|
      const double nlen = std::sqrt(dzdx * dzdx + dzdy * dzdy + 1);
      const double shade = std::max(0.0, (-dzdx * lx - dzdy * ly + lz) / nlen);
      cv::Vec3d c;
      double k;
      if (v >= 0) {
        c = ramp(kLand, 6, v / top);
        k = 0.35 + 0.65 * shade / lz;  // flat land keeps its palette colour
      } else {
        c = ramp(kWater, 5, v / floor_m);
        k = 0.75 + 0.25 * shade / lz;  // water: seen through, shading muted
      }
      k = std::clamp(k, 0.0, 1.25);
      bool coast = false;
      if (opt.coastline) {
        // A pixel is on the coastline if it is land and a 4-neighbour is water.
        coast = v >= 0 && (at(y, x + 1) < 0 || at(y, x - 1) < 0 || at(y + 1, x) < 0 || at(y - 1, x) < 0);
      }
      if (coast) c = {40, 35, 30}, k = 1;
      out(y, x) = {cv::saturate_cast<uint8_t>(c[2] * k), cv::saturate_cast<uint8_t>(c[1] * k),
                   cv::saturate_cast<uint8_t>(c[0] * k)};
    }
  return out;
}

}  // namespace reefgen
