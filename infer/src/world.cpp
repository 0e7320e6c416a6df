#include "reefgen/infer/world.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/error.hpp"
#include "reefgen/normal.hpp"
#include "reefgen/infer/edge_repair.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/ramp.hpp"
#include "reefgen/rng.hpp"

namespace reefgen::infer {

namespace {
// The sketch at the model's scale, as label ids and λ.
DecodedSketch at_model_scale(const DecodedSketch& s, double sketch_metres_per_px) {
  const double f = sketch_metres_per_px / kModelMetresPerPx;
  const cv::Size size(std::max(1, int(std::lround(s.label.cols * f))), std::max(1, int(std::lround(s.label.rows * f))));
  if (size == s.label.size()) return s;
  DecodedSketch out;
  cv::resize(s.label, out.label, size, 0, 0, cv::INTER_NEAREST);
  cv::resize(s.subsidence, out.subsidence, size, 0, 0, cv::INTER_LINEAR);
  return out;
}

// One forward over label/λ maps already square and a multiple of 2^depth.
cv::Mat1f forward_heights(model::GeneratorFile& g, const cv::Mat1b& label, const cv::Mat1f& sub, const InferOptions& o) {
  const torch::Tensor x =
      model::network_input(encode_labels(label, sub), g.g->options().in_channels, network_maturity(o)).unsqueeze(0);  // {1,in,S,S}
  const torch::Tensor y = forward_generator(g, x, resolve_engine(o), resolve(o, g), o.running_stats);  // {1,1,S,S}
  return model::tensor_to_height(y[0], g.range);
}

// Pads label/λ with abyss to a square side that is a multiple of unit, the
// content centred, its λ continued from the edge (a bright frame round a
// dark sketch made the network answer -47 m for a dark abyss that infer
// answers at -88 m); returns the offset of the content.
cv::Point pad_square(cv::Mat1b& label, cv::Mat1f& sub, int unit) {
  const int side = (std::max(label.rows, label.cols) + unit - 1) / unit * unit;
  const int top = (side - label.rows) / 2, left = (side - label.cols) / 2;
  cv::copyMakeBorder(label, label, top, side - label.rows - top, left, side - label.cols - left, cv::BORDER_CONSTANT,
                     cv::Scalar(kAbyss));
  cv::copyMakeBorder(sub, sub, top, side - sub.rows - top, left, side - sub.cols - left, cv::BORDER_REPLICATE);
  return {left, top};
}

// The coarse pass of one large island (its pixels: mask) over h, in place.
void add_large_forms(model::GeneratorFile& g, const cv::Mat1b& label, const cv::Mat1f& sub, const cv::Mat1b& mask,
                     const cv::Rect& box, double radius_px, const InferOptions& o, cv::Mat1f& h) {
  const double f = kCoarseIslandRadiusPx / radius_px;
  // The island's box grown by a quarter of its size: some sea round it.
  const cv::Rect crop = (box + cv::Size(box.width / 2, box.height / 2) - cv::Point(box.width / 4, box.height / 4)) &
                        cv::Rect(0, 0, label.cols, label.rows);
  const cv::Size small(std::max(1, int(std::lround(crop.width * f))), std::max(1, int(std::lround(crop.height * f))));
  cv::Mat1b l;
  cv::Mat1f s;
  cv::resize(label(crop), l, small, 0, 0, cv::INTER_NEAREST);
  cv::resize(sub(crop), s, small, 0, 0, cv::INTER_AREA);
  const cv::Point at = pad_square(l, s, 1 << g.g->options().depth);
  cv::Mat1f coarse;
  cv::resize(forward_heights(g, l, s, o)(cv::Rect(at, small)), coarse, crop.size(), 0, 0, cv::INTER_CUBIC);
  cv::Mat1f weight;
  mask(crop).convertTo(weight, CV_32F, 1.0 / 255);
  cv::GaussianBlur(weight, weight, cv::Size(0, 0), kCoarseFadePx / 2, kCoarseFadePx / 2, cv::BORDER_CONSTANT);
  // Faded in over the first half of the radius past the limit.
  const float size_w = float(std::clamp((radius_px - kLargeIslandRadiusPx) / (0.5 * kLargeIslandRadiusPx), 0.0, 1.0));
  cv::Mat1f region = h(crop);
  for (int y = 0; y < crop.height; ++y)
    for (int x = 0; x < crop.width; ++x) region(y, x) += size_w * weight(y, x) * (coarse(y, x) - region(y, x));
  cv::min(cv::max(h, g.range.lo_m), g.range.hi_m, h);
}

// Every painted island larger than kLargeIslandRadiusPx gets its coarse pass.
void add_large_islands(model::GeneratorFile& g, const cv::Mat1b& label, const cv::Mat1f& sub, const InferOptions& o,
                       cv::Mat1f& h) {
  cv::Mat1i comp;
  cv::Mat stats, centroids;
  const int n = cv::connectedComponentsWithStats(cv::Mat1b(label != uint8_t(kAbyss)), comp, stats, centroids, 8, CV_32S);
  for (int c = 1; c < n; ++c) {
    const double radius = std::sqrt(stats.at<int>(c, cv::CC_STAT_AREA) / M_PI);
    if (radius <= kLargeIslandRadiusPx) continue;
    const cv::Rect box(stats.at<int>(c, cv::CC_STAT_LEFT), stats.at<int>(c, cv::CC_STAT_TOP),
                       stats.at<int>(c, cv::CC_STAT_WIDTH), stats.at<int>(c, cv::CC_STAT_HEIGHT));
    add_large_forms(g, label, sub, cv::Mat1b(comp == c), box, radius, o, h);
  }
}
}  // namespace

cv::Mat1f world_model_heights(model::GeneratorFile& g, const DecodedSketch& sketch, double sketch_metres_per_px,
                              const InferOptions& o) {
  if (!(sketch_metres_per_px > 0) || !std::isfinite(sketch_metres_per_px))
    throw Error("world: metres per pixel must be a positive number");
  // Checked from the numbers before resampling: --world-size 1e8 would ask
  // for terabytes before the refusal.
  const double f = sketch_metres_per_px / kModelMetresPerPx;
  const double longest = std::max(sketch.label.cols, sketch.label.rows) * f;
  const int M = kWorldMarginPx;
  if (longest + 2 * M > kMaxWorldPassPx)
    throw Error("world: the sketch is " + std::to_string(std::lround(std::min(longest, 1e12))) +
                " px a side at the model's scale (23.4 m a pixel); one pass takes up to " +
                std::to_string(kMaxWorldPassPx - 2 * M) +
                " px: use a smaller sketch, or a smaller --metres-per-px or --world-size (less ground per pixel)");
  const DecodedSketch s = at_model_scale(sketch, sketch_metres_per_px);
  const int W = s.label.cols, H = s.label.rows;
  const int unit = 1 << g.g->options().depth;
  const int side = (std::max(W, H) + 2 * M + unit - 1) / unit * unit;
  if (side > kMaxWorldPassPx)
    throw Error("world: the sketch is " + std::to_string(W) + "×" + std::to_string(H) +
                " px at the model's scale; one pass takes up to " + std::to_string(kMaxWorldPassPx - 2 * M) +
                " px a side: use a smaller sketch, or a smaller --metres-per-px or --world-size");
  // Reflect the margin (at most the sketch's own size: a tiny sketch takes
  // what it has), then bright abyss up to the square side.
  const int my = std::min(M, H - 1), mx = std::min(M, W - 1);
  cv::Mat1b label;
  cv::Mat1f sub;
  cv::copyMakeBorder(s.label, label, my, my, mx, mx, cv::BORDER_REFLECT_101);
  cv::copyMakeBorder(s.subsidence, sub, my, my, mx, mx, cv::BORDER_REFLECT_101);
  cv::Mat1b label_sq = label.clone();
  cv::Mat1f sub_sq = sub.clone();
  const cv::Point at = pad_square(label_sq, sub_sq, unit);

  c10::InferenceMode inference;
  g.g->train(!o.running_stats);
  g.g->set_dropout_enabled(o.stochastic);
  if (o.stochastic) torch::manual_seed(derive_seed(o.seed, 0, "infer-dropout"));
  cv::Mat1f h = forward_heights(g, label_sq, sub_sq, o)(cv::Rect(at, label.size())).clone();
  add_large_islands(g, label, sub, o, h);
  cv::Mat1f out = h(cv::Rect(mx, my, W, H)).clone();
  // The ghost contours of the open sea and the painted lagoons, as infer
  // takes them off (the reflected margin already keeps the canvas edges
  // clean).
  smooth_open_sea(out);
  smooth_lagoon_floor(out, s.label);
  keep_painted_land(out, s.label);
  return out;
}

namespace {
// Where keep_painted_land raises a painted coast the network drew inland
// (docs/WORLDS.md), the kept coast is the smoothed painted line, not the
// painted staircase of model cells (raised cell by cell it came back as a
// staircase at 1:1): a shoreface runs through it.
constexpr double kCoastSmoothCells = 1.2;   // σ of the painted coast's smoothing, model cells
constexpr double kCoastOutsetCells = 0.3;   // the kept coast lies this far seaward of the smoothed line, cells (the staircase's outer corners stay land)
constexpr double kShorefaceMPerCell = 0.5;  // its rise through the coast, m a model cell (23.4 m: 2 %, a beach)
constexpr double kShorefaceCells = 2.5;     // how far it runs out to sea at that slope, cells
constexpr double kForeslopeMPerCell = 4;    // then down at this until it meets the sea floor, m a cell (17 %)
constexpr double kKeptZoneCells = 4;        // how far round a raised coast the shoreface reaches, cells
// The blurred mask is read as a distance between these shares (±5.2σ, past
// the foreslope's foot: nearer, the exact distance's staircase showed in the
// foreslope), handing over to the exact distance between the first and the
// second (a switch at one share stepped the shoreface there). The blur's
// kernel reaches ±6σ so the tails hold those shares.
constexpr double kMaskEps = 1e-7, kMaskBlendEps = 1e-6;

// Signed distance to the smoothed painted coast, cells (> 0 on land), the
// outset included: a blurred straight edge is Φ(x/σ), so σ·Φ⁻¹(m) is the
// distance where the blurred mask m is between kMaskEps and 1 − kMaskEps;
// beyond, the exact distance (far from the coast its staircase is
// harmless), blended in between kMaskBlendEps and kMaskEps.
// in: each land cell's distance to the painted water (0 on water).
cv::Mat1f coast_distance(const cv::Mat1b& land, const cv::Mat1f& in) {
  cv::Mat1f out;
  const int k = 2 * int(std::ceil(6 * kCoastSmoothCells)) + 1;
  cv::Mat1d md;
  land.convertTo(md, CV_64F, 1.0 / 255);
  cv::GaussianBlur(md, md, cv::Size(k, k), kCoastSmoothCells, kCoastSmoothCells, cv::BORDER_REPLICATE);
  cv::distanceTransform(cv::Mat1b(land == 0), out, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  const double log_eps = std::log(kMaskEps), log_blend = std::log(kMaskBlendEps);
  cv::Mat1f sd(land.size());
  for (int y = 0; y < land.rows; ++y)
    for (int x = 0; x < land.cols; ++x) {
      const double v = md(y, x), tail = std::min(v, 1 - v);
      const double exact = double(in(y, x) - out(y, x));
      double d = exact;
      if (tail > kMaskEps) {
        const double b = std::clamp((std::log(tail) - log_eps) / (log_blend - log_eps), 0.0, 1.0);
        d = exact + b * (kCoastSmoothCells * normal_quantile(v) - exact);
      }
      sd(y, x) = float(kCoastOutsetCells + d);
    }
  return sd;
}

float shoreface_m(double sd) {
  const double f = sd >= -kShorefaceCells ? kShorefaceMPerCell * sd
                                          : -kShorefaceMPerCell * kShorefaceCells - kForeslopeMPerCell * (-kShorefaceCells - sd);
  return std::min(kPaintedLandFloorM, float(f));
}
}  // namespace

void keep_painted_land(cv::Mat1f& h, const cv::Mat1b& label) {
  if (h.size() != label.size()) throw Error("internal: painted land and heights differ in size");
  cv::Mat1b land(label.size());
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < label.cols; ++x) land(y, x) = label(y, x) == kIsland || label(y, x) == kBeach ? 255 : 0;
  // Distance to the nearest painted water (1 on the coast). A canvas without
  // water has none: every cell is far inland.
  const bool all_land = cv::countNonZero(land) == int(land.total());
  cv::Mat1f d;
  if (all_land) d = cv::Mat1f(land.size(), float(1 + kPaintedLandRampPx));
  else cv::distanceTransform(land, d, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  // The painted cells the network left below their floor: round them the shoreface.
  cv::Mat1f raised(land.size(), 0.f);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      if (!land(y, x)) continue;
      const double t = std::clamp((d(y, x) - 1.0) / kPaintedLandRampPx, 0.0, 1.0);
      const float floor_m = kPaintedCoastFloorM + (kPaintedLandFloorM - kPaintedCoastFloorM) * float(smoothstep(t));
      if (h(y, x) < floor_m) raised(y, x) = 1.f;
      h(y, x) = std::max(h(y, x), floor_m);
    }
  if (all_land || cv::countNonZero(raised) == 0) return;
  cv::dilate(raised, raised, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * int(kKeptZoneCells) + 1, 2 * int(kKeptZoneCells) + 1)));
  cv::GaussianBlur(raised, raised, cv::Size(0, 0), 0.5 * kKeptZoneCells, 0.5 * kKeptZoneCells, cv::BORDER_REPLICATE);
  const cv::Mat1f sd = coast_distance(land, d);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      const float w = std::min(1.f, 2.f * raised(y, x));
      if (w <= 0) continue;
      const float f = shoreface_m(sd(y, x));
      if (f > h(y, x)) h(y, x) += w * (f - h(y, x));
    }
}

}  // namespace reefgen::infer
