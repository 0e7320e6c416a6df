#pragma once
#include <opencv2/core.hpp>

namespace reefgen {

struct PreviewOptions {
  double land_top_m = 0;      // m; heights at or above are drawn white; 0 = use the field's maximum (≥ 50 m)
  double sea_floor_m = -100;  // m; depths at or below are drawn darkest blue
  double sun_azimuth_deg = 315;   // deg, 0 = +x, counter-clockwise (315: light from the top-left of the image)
  double sun_elevation_deg = 40;  // deg above the horizon
  double metres_per_px = 0;       // m; 0 = assume a 2 km wide canvas (vertical scale of the shading)
  bool coastline = true;          // draw the 0 m contour in a dark line
};

// Hypsometric colours (deep blue → turquoise shallows | sand → green → brown
// → white) modulated by hill-shading, with a dark 0 m coastline. BGR 8-bit.
cv::Mat3b render_preview(const cv::Mat1f& height_m, const PreviewOptions& opt = {});

}  // namespace reefgen
