#include "reefgen/terrain/world_layers.hpp"

#include <algorithm>

#include <opencv2/imgproc.hpp>

#include "layers_parts.hpp"
#include "reefgen/error.hpp"
#include "reefgen/labels.hpp"

namespace reefgen::terrain {

using namespace detail;

namespace {

// Rows a band holds when the whole world is read for its scales.
constexpr int kScaleBandRows = 1024;

// `src` (any resolution over the world's ground) read at the centres of the
// pixels of `tile` of a field of `size`: pixel x sits at (x + ½)·src/size − ½
// of src. The value depends on the position only, whatever the tile.
cv::Mat1f sample_at(const cv::Mat1f& src, cv::Size size, const cv::Rect& tile, int interpolation) {
  cv::Mat1f mx(tile.size()), my(tile.size());
  const double sx = double(src.cols) / size.width, sy = double(src.rows) / size.height;
  for (int r = 0; r < tile.height; ++r) {
    const float v = float((tile.y + r + 0.5) * sy - 0.5);
    for (int c = 0; c < tile.width; ++c) {
      mx(r, c) = float((tile.x + c + 0.5) * sx - 0.5);
      my(r, c) = v;
    }
  }
  cv::Mat1f out;
  cv::remap(src, out, mx, my, interpolation, cv::BORDER_REPLICATE);
  return out;
}

// Metres a sample of `h` spans when it covers the world's ground with its
// corner samples on the world's (resample_corners' rule; the world itself: its own).
double spacing_of(const cv::Mat1f& h, const WorldLayerField& f) {
  return h.cols == f.size.width ? f.metres_per_px : f.metres_per_px * (f.size.width - 1) / std::max(1, h.cols - 1);
}

void check_tile(const cv::Mat1f& h, const WorldLayerField& f, const cv::Rect& tile) {
  if (f.flow_area_m2.empty()) throw Error("world layers: the coarse field is empty");
  if (h.empty() || (tile & cv::Rect(0, 0, h.cols, h.rows)) != tile || tile.empty())
    throw Error("world layers: the tile lies outside the world");
}

// The direct wear and deposit (h − before) and the settled sediment of `tile`.
void wear_and_deposit(const cv::Mat1f& h, const WorldLayerField& f, const cv::Rect& tile, const cv::Mat1f& slope_deg,
                      double settle_deg, cv::Mat1f& wear_m, cv::Mat1f& deposit_m) {
  deposit_m = sample_at(f.settled_m, h.size(), tile, cv::INTER_LINEAR);
  wear_m = cv::Mat1f(tile.size(), 0.f);
  if (f.before_m.empty()) return;
  const cv::Mat1f before = sample_at(f.before_m, h.size(), tile, cv::INTER_CUBIC);
  for (int y = 0; y < tile.height; ++y)
    for (int x = 0; x < tile.width; ++x) {
      const float d = h(tile.y + y, tile.x + x) - before(y, x);
      if (d < 0) wear_m(y, x) = -d;
      else if (raised_is_fill(h, tile.y + y, tile.x + x, slope_deg(y, x), settle_deg)) deposit_m(y, x) += d;
    }
}

}  // namespace

WorldLayerField world_layer_field(const cv::Mat1f& h, const cv::Mat1f& before, const cv::Mat1b& region, double dx,
                                  const LayerParams& p, int threads) {
  check_inputs(h, cv::Mat1f(), cv::Mat1b(), dx);
  WorldLayerField f;
  f.size = h.size();
  f.metres_per_px = dx;
  f.before_m = before;
  const cv::Size cs((h.cols + kWorldLayerCoarsening - 1) / kWorldLayerCoarsening,
                    (h.rows + kWorldLayerCoarsening - 1) / kWorldLayerCoarsening);
  const double dx_c = dx * h.cols / cs.width;
  cv::Mat1f hc, before_c;
  cv::resize(h, hc, cs, 0, 0, cv::INTER_AREA);
  if (!before.empty()) cv::resize(before, before_c, cs, 0, 0, cv::INTER_CUBIC);
  cv::Mat1f slope;
  cv::Mat3f normal;
  slope_and_normals(hc, dx_c, slope, normal, threads);
  normal.release();
  FlowGraph graph;
  cv::Rect box;
  f.flow_area_m2 = drainage_area(hc, dx_c, graph, box);
  cv::Mat1f wear = before_c.empty() ? cv::Mat1f(cs, 0.f) : cv::Mat1f(cv::max(before_c - hc, 0.f));
  f.settled_m = cv::Mat1f(cs, 0.f);
  settle_sediment(graph, box, hc, wear, slope, dx_c, p.settle_deg, f.settled_m);
  graph = FlowGraph();
  cv::Mat1b region_c;
  if (region.empty()) region_c = regions_of_heights(hc, p);
  else cv::resize(region, region_c, cs, 0, 0, cv::INTER_NEAREST);
  const double sigma_c = p.region_blend_m / dx_c;
  f.abyss = region_share(region_c, kAbyss, sigma_c);
  f.reef = region_share(region_c, kReef, sigma_c);
  f.beach = region_share(region_c, kBeach, sigma_c);
  return f;
}

Layers world_layers_tile(const cv::Mat1f& h, const WorldLayerField& f, const cv::Rect& tile, const LayerParams& p,
                         int threads) {
  check_tile(h, f, tile);
  const double dx = spacing_of(h, f);
  Layers L;
  // Slopes read one sample round the tile (the canvas edge stays one-sided).
  const cv::Rect halo = (tile + cv::Size(2, 2) - cv::Point(1, 1)) & cv::Rect(0, 0, h.cols, h.rows);
  cv::Mat1f slope;
  cv::Mat3f normal;
  slope_and_normals(h(halo), dx, slope, normal, threads);
  const cv::Rect inner = tile - halo.tl();
  L.slope_deg = slope(inner).clone();
  L.normal = normal(inner).clone();
  wear_and_deposit(h, f, tile, L.slope_deg, p.settle_deg, L.wear_m, L.deposit_m);
  L.flow_area_m2 = sample_at(f.flow_area_m2, h.size(), tile, cv::INTER_LINEAR);
  const cv::Mat1f abyss = sample_at(f.abyss, h.size(), tile, cv::INTER_LINEAR),
                  reef = sample_at(f.reef, h.size(), tile, cv::INTER_LINEAR),
                  beach = sample_at(f.beach, h.size(), tile, cv::INTER_LINEAR);
  for (auto& w : L.weight) w.create(tile.size());
  for_rows(tile.height, threads, [&](int y) {
    for (int x = 0; x < tile.width; ++x) {
      const float v = h(tile.y + y, tile.x + x);
      // Drainage is land's: the sea drains nothing (as compute_layers), and a
      // land sample drains at least itself (the coarse grid, sampled along a
      // coast, gave land samples next to its sea cells less, or nothing).
      L.flow_area_m2(y, x) = v > 0 ? std::max(L.flow_area_m2(y, x), float(dx * dx)) : 0.f;
      float w[kNumMaterials];
      material_weights({v, L.slope_deg(y, x), L.flow_area_m2(y, x), L.deposit_m(y, x), abyss(y, x), reef(y, x),
                        beach(y, x)},
                       p, w);
      for (int m = 0; m < kNumMaterials; ++m) L.weight[size_t(m)](y, x) = w[m];
    }
  });
  return L;
}

LayerScales world_layer_scales(const cv::Mat1f& h, const WorldLayerField& f, const LayerParams& p) {
  LayerScales s;
  cv::minMaxLoc(f.flow_area_m2, nullptr, &s.flow_area_m2);
  const double dx = spacing_of(h, f);
  for (int y0 = 0; y0 < h.rows; y0 += kScaleBandRows) {
    const cv::Rect band(0, y0, h.cols, std::min(kScaleBandRows, h.rows - y0));
    // The band's slopes as its tiles read them (one row round it).
    const cv::Rect halo = (band + cv::Size(0, 2) - cv::Point(0, 1)) & cv::Rect(0, 0, h.cols, h.rows);
    cv::Mat1f slope, wear, deposit;
    cv::Mat3f normal;
    slope_and_normals(h(halo), dx, slope, normal, 1);
    wear_and_deposit(h, f, band, slope(band - halo.tl()), p.settle_deg, wear, deposit);
    double w = 0, d = 0;
    cv::minMaxLoc(wear, nullptr, &w);
    cv::minMaxLoc(deposit, nullptr, &d);
    s.wear_m = std::max(s.wear_m, w);
    s.deposit_m = std::max(s.deposit_m, d);
  }
  return s;
}

}  // namespace reefgen::terrain
