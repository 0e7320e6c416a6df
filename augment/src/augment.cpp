#include "reefgen/augment/augment.hpp"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "reefgen/files.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/reef.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/terrain/noise.hpp"

namespace reefgen::augment {

namespace {
void check(const Pair& p) {
  if (p.height_m.empty() || p.height_m.size() != p.label.size() || p.label.size() != p.subsidence.size())
    throw Error("augment: height, label and subsidence must be non-empty and of the same size");
}
}  // namespace

// The open ocean's height on the canvas border: the highest border cell
// labelled abyss, or `fallback` when none is.
float border_ocean_m(const Pair& p, double fallback) {
  std::vector<float> v;
  const int W = p.height_m.cols, H = p.height_m.rows;
  auto take = [&](int y, int x) {
    if (p.label(y, x) == kAbyss) v.push_back(p.height_m(y, x));
  };
  for (int x = 0; x < W; ++x) take(0, x), take(H - 1, x);
  for (int y = 1; y + 1 < H; ++y) take(y, 0), take(y, W - 1);
  if (v.empty()) return float(fallback);
  return *std::max_element(v.begin(), v.end());
}

Pair affine(const Pair& p, double angle_deg, double scale, bool flip_x, double ocean_m) {
  check(p);
  if (!(scale > 0) || !std::isfinite(angle_deg)) throw Error("augment: scale must be > 0 and the angle finite");
  const cv::Point2f c((p.height_m.cols - 1) / 2.f, (p.height_m.rows - 1) / 2.f);
  cv::Mat m = cv::getRotationMatrix2D(c, angle_deg, scale);  // 2×3, CV_64F
  if (flip_x) {
    // Compose with x → (W−1) − x applied first.
    m.at<double>(0, 2) += m.at<double>(0, 0) * (p.height_m.cols - 1);
    m.at<double>(1, 2) += m.at<double>(1, 0) * (p.height_m.cols - 1);
    m.at<double>(0, 0) = -m.at<double>(0, 0);
    m.at<double>(1, 0) = -m.at<double>(1, 0);
  }
  Pair out;
  const cv::Size sz = p.height_m.size();
  // The sea floor has relief (docs/REEF.md): cells from outside the canvas
  // continue its edge (no straight step along the rotated canvas), but never
  // above the highest abyss cell of its border, so land cut by the edge is not
  // smeared outwards.
  cv::warpAffine(p.height_m, out.height_m, m, sz, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  cv::Mat1b inside;
  cv::warpAffine(cv::Mat1b(p.height_m.size(), uint8_t(1)), inside, m, sz, cv::INTER_NEAREST, cv::BORDER_CONSTANT,
                 cv::Scalar(0));
  const float ocean = border_ocean_m(p, ocean_m);
  for (int y = 0; y < sz.height; ++y)
    for (int x = 0; x < sz.width; ++x)
      if (!inside(y, x)) out.height_m(y, x) = std::min(out.height_m(y, x), ocean);
  cv::warpAffine(p.label, out.label, m, sz, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(kAbyss));
  cv::warpAffine(p.subsidence, out.subsidence, m, sz, cv::INTER_NEAREST, cv::BORDER_REPLICATE);
  return out;
}

namespace {
template <class T>
cv::Mat_<T> roll(const cv::Mat_<T>& m, int dx, int dy) {
  const int W = m.cols, H = m.rows;
  dx = ((dx % W) + W) % W;
  dy = ((dy % H) + H) % H;
  cv::Mat_<T> out(m.size());
  for (int y = 0; y < H; ++y) {
    const T* src = m.template ptr<T>(y);
    T* dst = out.template ptr<T>((y + dy) % H);
    for (int x = 0; x < W; ++x) dst[(x + dx) % W] = src[x];
  }
  return out;
}
}  // namespace

// Gaussian σ (px) over the distance field: takes its staircase ripples off.
constexpr double kFlankDistanceSmoothPx = 2;

Pair redraw_flank(const Pair& p, const FlankShape& f, uint64_t seed) {
  check(p);
  const cv::Mat1b abyss = p.label == kAbyss;
  const int abyss_cells = cv::countNonZero(abyss);
  if (abyss_cells == 0 || abyss_cells == abyss.rows * abyss.cols) return p;
  // Distance (px) from each abyss cell to the nearest other cell: 1 next to
  // the reef, whose outline lies half a cell further in.
  cv::Mat1f dist_px;
  cv::distanceTransform(abyss, dist_px, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  // The distance to a pixel staircase ripples along it, and the ripples run
  // outwards as faint spokes; the generator's polar distance has none.
  cv::GaussianBlur(dist_px, dist_px, cv::Size(), kFlankDistanceSmoothPx);
  const terrain::GradientNoise2 noise(derive_seed(seed, 0, "flank-relief"));
  Pair out{p.height_m.clone(), p.label.clone(), p.subsidence.clone()};
  for (int y = 0; y < out.height_m.rows; ++y)
    for (int x = 0; x < out.height_m.cols; ++x) {
      if (!abyss(y, x)) continue;
      const double d = std::max(0.0, dist_px(y, x) - 0.5) * f.metres_per_px;
      const double n = noise.fbm(float(x * f.metres_per_px / procgen::kAbyssReliefFeatureM),
                                 float(y * f.metres_per_px / procgen::kAbyssReliefFeatureM), 3);
      out.height_m(y, x) = float(procgen::flank_height_m(d, f.floor_m, f.foot_m, f.decay_m, f.relief_m, n));
    }
  return out;
}

Pair translate_wrap(const Pair& p, int dx, int dy) {
  check(p);
  return {roll(p.height_m, dx, dy), roll(p.label, dx, dy), roll(p.subsidence, dx, dy)};
}

double iou(const cv::Mat1b& a, const cv::Mat1b& b) {
  CV_Assert(a.size() == b.size());
  const int inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni == 0 ? 0.0 : static_cast<double>(inter) / uni;
}

cv::Mat1b footprint(const Pair& p) { return p.label != static_cast<uint8_t>(kAbyss); }

PasteResult copy_paste(const std::vector<Pair>& islands, uint64_t seed, double max_iou, int tries, double smax_k) {
  if (islands.empty()) throw Error("copy_paste: no islands");
  for (const auto& p : islands) {
    check(p);
    if (p.height_m.size() != islands[0].height_m.size()) throw Error("copy_paste: islands differ in size");
  }
  const int W = islands[0].height_m.cols, H = islands[0].height_m.rows;
  Rng rng(seed, 0, "copy-paste");
  PasteResult r;
  std::vector<Pair> placed;
  std::vector<cv::Mat1b> masks;
  for (const auto& isl : islands) {
    for (int t = 0; t < tries; ++t) {
      const cv::Point off(static_cast<int>(rng.uniform_int(0, W - 1)), static_cast<int>(rng.uniform_int(0, H - 1)));
      // The first island stays where it is: a sample always contains one intact island.
      const Pair moved = placed.empty() ? isl : translate_wrap(isl, off.x, off.y);
      const cv::Mat1b m = footprint(moved);
      bool ok = true;
      for (const auto& other : masks) ok = ok && iou(m, other) <= max_iou;
      if (!ok) continue;
      r.offsets.push_back(placed.empty() ? cv::Point(0, 0) : off);
      placed.push_back(moved);
      masks.push_back(m);
      break;
    }
  }
  r.placed = static_cast<int>(placed.size());
  // Merge: heights by smooth maximum, labels from the higher island.
  Pair& out = r.pair;
  out = {placed[0].height_m.clone(), placed[0].label.clone(), placed[0].subsidence.clone()};
  for (size_t i = 1; i < placed.size(); ++i)
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const float a = out.height_m(y, x), b = placed[i].height_m(y, x);
        if (b > a) {
          out.label(y, x) = placed[i].label(y, x);
          out.subsidence(y, x) = placed[i].subsidence(y, x);
        }
        out.height_m(y, x) = static_cast<float>(procgen::smax(a, b, smax_k));
      }
  // Pixels no footprint covers are abyss (the higher of two abysses could
  // otherwise hand a pixel to an island's outer slope label).
  cv::Mat1b covered(H, W, uint8_t(0));
  for (const auto& m : masks) covered |= m;
  out.label.setTo(static_cast<uint8_t>(kAbyss), ~covered);
  return r;
}

}  // namespace reefgen::augment
