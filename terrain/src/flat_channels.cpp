#include "reefgen/terrain/flat_channels.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"

namespace reefgen::terrain {

namespace {

// Land cells whose slope (central differences, one-sided at the border) is
// below kFlatChannelMaxSlope.
cv::Mat1b flat_land(const cv::Mat1f& h, double mpp) {
  cv::Mat1b flat(h.size(), uchar(0));
  const double max_rise = kFlatChannelMaxSlope * mpp;
  for (int y = 0; y < h.rows; ++y) {
    const int ya = std::max(0, y - 1), yb = std::min(h.rows - 1, y + 1);
    for (int x = 0; x < h.cols; ++x) {
      if (!(h(y, x) > 0)) continue;
      const int xa = std::max(0, x - 1), xb = std::min(h.cols - 1, x + 1);
      const double gx = (double(h(y, xb)) - h(y, xa)) / std::max(1, xb - xa);
      const double gy = (double(h(yb, x)) - h(ya, x)) / std::max(1, yb - ya);
      if (std::hypot(gx, gy) < max_rise) flat(y, x) = 255;
    }
  }
  return flat;
}

// Whether a cell lies within 2 cells of the sea (at or below 0 m): the land
// cell on the shore itself is never flat by central differences, as its
// neighbour is the sea.
bool beside_sea(const cv::Mat1f& h, int y, int x) {
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx) {
      const int yy = y + dy, xx = x + dx;
      if (yy >= 0 && xx >= 0 && yy < h.rows && xx < h.cols && !(h(yy, xx) > 0)) return true;
    }
  return false;
}

}  // namespace

FlatChannelStats flat_channel_stats(const cv::Mat1f& height_m, double metres_per_px) {
  if (height_m.empty()) throw Error("flat channels: empty height field");
  if (!(metres_per_px > 0)) throw Error("flat channels: the cell size must be > 0 m");
  FlatChannelStats s;
  const cv::Mat1b flat = flat_land(height_m, metres_per_px);
  s.land_km2 = double(cv::countNonZero(height_m > 0)) * metres_per_px * metres_per_px * 1e-6;
  cv::Mat1i labels, boxes;
  cv::Mat centroids;
  const int n = cv::connectedComponentsWithStats(flat, labels, boxes, centroids, 8, CV_32S);
  // Only a component whose axis-aligned box is at least 25/√2 px on a side can
  // be 25 px long: gather the points of those alone.
  const int min_box = int(std::floor(kFlatChannelMinLengthPx / std::sqrt(2.0)));
  std::vector<int> slot(size_t(n), -1);
  std::vector<uint8_t> by_sea(size_t(n), 0);
  std::vector<std::vector<cv::Point>> points;
  for (int i = 1; i < n; ++i)
    if (std::max(boxes(i, cv::CC_STAT_WIDTH), boxes(i, cv::CC_STAT_HEIGHT)) >= min_box)
      slot[size_t(i)] = int(points.size()), points.emplace_back();
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
      if (const int l = labels(y, x); l > 0 && slot[size_t(l)] >= 0) {
        points[size_t(slot[size_t(l)])].emplace_back(x, y);
        if (!by_sea[size_t(l)] && beside_sea(height_m, y, x)) by_sea[size_t(l)] = 1;
      }
  std::vector<uint8_t> slot_by_sea(points.size(), 0);
  for (int i = 1; i < n; ++i)
    if (slot[size_t(i)] >= 0) slot_by_sea[size_t(slot[size_t(i)])] = by_sea[size_t(i)];
  for (size_t k = 0; k < points.size(); ++k) {
    const auto& p = points[k];
    const cv::RotatedRect r = cv::minAreaRect(p);
    // A rectangle round pixel centres is one pixel short on each side.
    const double length = std::max(r.size.width, r.size.height) + 1;
    const double width = std::max(1.0, double(std::min(r.size.width, r.size.height)) + 1);
    if (length >= kFlatChannelMinLengthPx && length >= kFlatChannelMinElongation * width) {
      if (slot_by_sea[k]) {
        ++s.coastal;
        continue;
      }
      ++s.channels;
      s.longest_px = std::max(s.longest_px, length);
    }
  }
  s.per_1000_km2 = s.land_km2 > 0 ? 1000.0 * double(s.channels) / s.land_km2 : 0;
  return s;
}

}  // namespace reefgen::terrain
