#include "reefgen/procgen/generator.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/files.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/terrain/erosion.hpp"
#include "reefgen/terrain/noise.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/procgen/reef.hpp"
#include "reefgen/ramp.hpp"

namespace reefgen::procgen {

using terrain::GradientNoise2;
using terrain::NoiseTile;

// ---------------------------------------------------------------- pure pieces

double smax(double a, double b, double k) {
  const double m = std::max(a, b);
  const double d2k = 2.0 * k * std::fabs(a - b);
  if (d2k > 60.0) return m;               // the correction is < 1e-24 m
  if (d2k < 1e-9) return m + 0.5 / k;     // limit δ/(e^{2kδ}−1) → 1/(2k)
  return m + std::fabs(a - b) / std::expm1(d2k);
}

SmoothMaxTable::SmoothMaxTable(double k)
    : scale_(static_cast<float>(2.0 * k * kPerUnit)), c_(kMaxT * kPerUnit + 2) {
  for (size_t i = 0; i < c_.size(); ++i) {
    const double t = static_cast<double>(i) / kPerUnit;  // t = 2kδ
    const double d = t / (2.0 * k);
    c_[i] = static_cast<float>(smax(0.0, d, k) - d);
  }
}

namespace {
inline double s_curve(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return smoothstep(t);
}
}  // namespace

double coral_height_m(double x, const CoralParams& c) {
  if (x <= c.back_end) return c.back_m;
  if (x < c.crest_begin) return c.back_m + (c.crest_m - c.back_m) * s_curve((x - c.back_end) / (c.crest_begin - c.back_end));
  if (x <= c.crest_end) return c.crest_m;
  if (x < 1.0) return c.crest_m + (c.abyss_m - c.crest_m) * s_curve((x - c.crest_end) / (1.0 - c.crest_end));
  return c.abyss_m;
}

double profile_to_metres(double p, const HeightMapping& m) {
  if (p <= m.sea_level) return m.floor_m * (m.sea_level - p) / m.sea_level;
  return m.peak_m * (p - m.sea_level) / (1.0 - m.sea_level);
}

double parametric_distance(double r, const std::array<double, 5>& R) {
  double lo = 0;
  for (int i = 0; i < 5; ++i) {
    if (r < R[i]) return i + (r - lo) / (R[i] - lo);
    lo = R[i];
  }
  return 5.0;
}

float fast_atan2(float y, float x) {
  const float ax = std::fabs(x), ay = std::fabs(y);
  const float mx = std::max(ax, ay), mn = std::min(ax, ay);
  if (mx == 0.f) return 0.f;
  const float a = mn / mx, s = a * a;
  // Minimax polynomial for atan on [0, 1], max error ≈ 1e-5 rad.
  float r = ((((((-0.01172120f * s + 0.05265332f) * s - 0.11643287f) * s + 0.19354346f) * s - 0.33262347f) * s) +
             0.99997726f) * a;
  if (ay > ax) r = 1.57079637f - r;
  if (x < 0.f) r = 3.14159274f - r;
  return y < 0.f ? -r : r;
}

// ---------------------------------------------------------------- outlines

OutlineTable::OutlineTable(const std::array<std::vector<double>, 5>& outlines, double min_gap)
    : r_(kAngles + 1) {
  for (int t = 0; t < kAngles; ++t) {
    const double theta = 2.0 * M_PI * t / kAngles;
    double prev = 0;
    for (int i = 0; i < 5; ++i) {
      const double r = std::max(periodic_catmull_rom(outlines[i], theta), prev + min_gap);
      r_[t][i] = static_cast<float>(r);
      prev = r;
    }
  }
  r_[kAngles] = r_[0];
  float outer = 0;
  for (const auto& row : r_) outer = std::max(outer, row[4]);
  outer2_ = outer * outer;
}

std::array<double, 5> OutlineTable::radii(double theta) const {
  double tt = theta / (2.0 * M_PI);
  tt = (tt - std::floor(tt)) * kAngles;
  const int i = std::min(static_cast<int>(tt), kAngles - 1);
  const double f = tt - i;
  std::array<double, 5> R;
  for (int j = 0; j < 5; ++j) R[j] = r_[i][j] + f * (r_[i + 1][j] - r_[i][j]);
  return R;
}

float OutlineTable::xt(float x, float y) const {
  const float r2 = x * x + y * y;
  if (r2 >= outer2_) return 5.f;  // open ocean: the canvas corners, most wind-displaced sources
  const float r = std::sqrt(r2);
  float tt = fast_atan2(y, x) * static_cast<float>(kAngles / (2.0 * M_PI));
  if (tt < 0.f) tt += kAngles;
  int i = static_cast<int>(tt);
  if (i >= kAngles) i = kAngles - 1;
  const float f = tt - i;
  const auto& a = r_[i];
  const auto& b = r_[i + 1];
  float lo = 0.f;
  for (int j = 0; j < 5; ++j) {
    const float R = a[j] + f * (b[j] - a[j]);
    if (r < R) return j + (r - lo) / (R - lo);
    lo = R;
  }
  return 5.f;
}

// ---------------------------------------------------------------- wind

namespace {

struct Segment {
  float ax, ay, dx, dy;  // start and direction (end − start)
  float inv_len2;
  float ux, uy;          // unit tangent
};

struct Chunk {
  float x0, y0, x1, y1;  // bounding box of the chunk's segments
  int begin, end;
};

// Closest-segment queries on one stroke. Nodes are visited in raster order and
// the previous node's closest segment gives a tight first bound, so most chunks
// are rejected by their bounding box alone: this is what keeps Φ cheap.
class StrokeIndex {
 public:
  static constexpr int kChunk = 8;
  explicit StrokeIndex(const WindStroke& s) {
    // 4 samples per control interval: the random walks are already smooth, and
    // the segment count is what the closest-point search pays for.
    const auto poly = sample_open_catmull_rom(s.points, 4);
    for (size_t i = 0; i + 1 < poly.size(); ++i) {
      const float dx = float(poly[i + 1].x - poly[i].x), dy = float(poly[i + 1].y - poly[i].y);
      const float l2 = dx * dx + dy * dy;
      if (l2 < 1e-14f) continue;  // repeated point: no tangent
      const float l = std::sqrt(l2);
      segs_.push_back({float(poly[i].x), float(poly[i].y), dx, dy, 1.f / l2, dx / l, dy / l});
    }
    for (int b = 0; b < (int)segs_.size(); b += kChunk) {
      Chunk c{1e30f, 1e30f, -1e30f, -1e30f, b, std::min<int>(b + kChunk, (int)segs_.size())};
      for (int i = c.begin; i < c.end; ++i) {
        const auto& g = segs_[i];
        c.x0 = std::min({c.x0, g.ax, g.ax + g.dx}); c.x1 = std::max({c.x1, g.ax, g.ax + g.dx});
        c.y0 = std::min({c.y0, g.ay, g.ay + g.dy}); c.y1 = std::max({c.y1, g.ay, g.ay + g.dy});
      }
      chunks_.push_back(c);
    }
  }
  bool empty() const { return segs_.empty(); }

  // Squared distance to the closest segment and its index (ties: lowest index).
  float closest(float px, float py, int& best) const {
    float best_d2 = dist2(segs_[best], px, py);
    int best_i = best;
    for (const auto& c : chunks_) {
      const float ex = std::max({c.x0 - px, 0.f, px - c.x1}), ey = std::max({c.y0 - py, 0.f, py - c.y1});
      if (ex * ex + ey * ey > best_d2) continue;
      for (int i = c.begin; i < c.end; ++i) {
        const float d2 = dist2(segs_[i], px, py);
        if (d2 < best_d2 || (d2 == best_d2 && i < best_i)) { best_d2 = d2; best_i = i; }
      }
    }
    best = best_i;
    return best_d2;
  }
  const Segment& seg(int i) const { return segs_[i]; }

 private:
  static float dist2(const Segment& g, float px, float py) {
    const float wx = px - g.ax, wy = py - g.ay;
    const float t = std::clamp((wx * g.dx + wy * g.dy) * g.inv_len2, 0.f, 1.f);
    const float ex = wx - t * g.dx, ey = wy - t * g.dy;
    return ex * ex + ey * ey;
  }
  std::vector<Segment> segs_;
  std::vector<Chunk> chunks_;
};

// Bilinear sample of a node field (n+1)² at canvas point (x, y), clamped to
// the canvas (beyond it the field is extended by its border values).
template <class T>
inline T sample_nodes(const cv::Mat_<T>& f, int n, float x, float y) {
  const float gx = std::clamp((x + 1.f) * 0.5f * n, 0.f, float(n));
  const float gy = std::clamp((1.f - y) * 0.5f * n, 0.f, float(n));
  const int ix = std::min(static_cast<int>(gx), n - 1), iy = std::min(static_cast<int>(gy), n - 1);
  const float fx = gx - ix, fy = gy - iy;
  const T* r0 = f[iy];
  const T* r1 = f[iy + 1];
  const T top = r0[ix] + fx * (r0[ix + 1] - r0[ix]);
  const T bot = r1[ix] + fx * (r1[ix + 1] - r1[ix]);
  return top + fy * (bot - top);
}

}  // namespace

cv::Mat2f wind_field(const std::vector<WindStroke>& strokes, int n) {
  cv::Mat2f phi(n + 1, n + 1, cv::Vec2f(0.f, 0.f));
  for (const auto& s : strokes) {
    if (s.strength == 0) continue;
    const StrokeIndex idx(s);
    if (idx.empty()) continue;
    const float inv_2s2 = float(1.0 / (2.0 * s.width * s.width));
    const float S = float(s.strength);
    int best = 0;
    for (int r = 0; r <= n; ++r) {
      const float y = 1.f - 2.f * r / n;
      cv::Vec2f* row = phi.ptr<cv::Vec2f>(r);
      for (int c = 0; c <= n; ++c) {
        const float x = -1.f + 2.f * c / n;
        const float d2 = idx.closest(x, y, best);
        const float g = S * std::exp(-d2 * inv_2s2);
        row[c][0] += g * idx.seg(best).ux;
        row[c][1] += g * idx.seg(best).uy;
      }
    }
  }
  return phi;
}

cv::Mat1f resistance_field(const OutlineTable& outlines, const std::vector<float>& rho_of_xt, int m) {
  const float lut_scale = float(rho_of_xt.size() - 1) / 5.f;
  cv::Mat1f rho(m + 1, m + 1);
  std::vector<float> px(m + 1), py(m + 1), xt(m + 1);
  for (int r = 0; r <= m; ++r) {
    for (int c = 0; c <= m; ++c) px[c] = -1.f + 2.f * c / m, py[c] = 1.f - 2.f * r / m;
    outlines.xt_row(px.data(), py.data(), m + 1, xt.data());
    for (int c = 0; c <= m; ++c) rho(r, c) = rho_of_xt[static_cast<int>(xt[c] * lut_scale + 0.5f)];
  }
  return rho;
}


cv::Mat2f integrate_warp(const cv::Mat2f& phi, const cv::Mat1f& resistance, int substeps) {
  const int n = phi.rows - 1, m = resistance.rows - 1;
  cv::Mat2f D(phi.size(), cv::Vec2f(0.f, 0.f)), next(phi.size());
  const float inv_steps = 1.f / substeps;
  for (int k = 0; k < substeps; ++k) {
    for (int r = 0; r <= n; ++r) {
      const float y = 1.f - 2.f * r / n;
      for (int c = 0; c <= n; ++c) {
        const float x = -1.f + 2.f * c / n;
        const cv::Vec2f d = D(r, c);
        // Resistance of the material currently at this node (it came from p + D).
        const float rho = sample_nodes(resistance, m, x + d[0], y + d[1]);
        const cv::Vec2f v = phi(r, c) * ((1.f - rho) * inv_steps);
        const float qx = x - v[0], qy = y - v[1];
        const cv::Vec2f dq = sample_nodes(D, n, qx, qy);
        next(r, c) = cv::Vec2f(qx + dq[0] - x, qy + dq[1] - y);
      }
    }
    std::swap(D, next);
  }
  return D;
}

// ---------------------------------------------------------------- generate

namespace {

void check_render_options(const RenderOptions& opt) {
  if (opt.size_px < kMinGenerateSidePx || opt.size_px > kMaxSidePx)
    throw Error("size = " + std::to_string(opt.size_px) + " is out of range; expected [" +
                std::to_string(kMinGenerateSidePx) + ", " + std::to_string(kMaxSidePx) + "]");
  if (opt.warp_grid < 4 || opt.warp_grid > 1024)
    throw Error("warp_grid = " + std::to_string(opt.warp_grid) + " is out of range; expected [4, 1024]");
  if (opt.resistance_grid < 4 || opt.resistance_grid > 4096)
    throw Error("resistance_grid = " + std::to_string(opt.resistance_grid) + " is out of range; expected [4, 4096]");
  if (opt.wind_grid < 4 || opt.wind_grid > 1024)
    throw Error("wind_grid = " + std::to_string(opt.wind_grid) + " is out of range; expected [4, 1024]");
}

// Everything that depends on x̃ alone, tabulated once per island at
// kEntries points over [0, 5]: resistance ρ, subsided volcano h_sub, coral,
// and their smooth maximum (the height without erosion or noise).
// Coral height (m) where no coral grows: far below any ground, so the smooth
// maximum returns the ground unchanged.
constexpr float kNoCoral = -1e4f;

struct ProfileTables {
  static constexpr int kEntries = 4097;
  const float scale = (kEntries - 1) / 5.f;  // entries per unit of x̃
  std::vector<float> rho, hsub, coral, merged;

  // With reef geomorphology the volcano is shaped to the lagoon shore
  // (shore_height_m) and there is no coral here (kNoCoral): the rim, the
  // lagoon basin and the sea floor beyond the reef come from apply_reef.
  ProfileTables(const IslandSpec& spec, double lagoon_depth_m)
      : rho(kEntries), hsub(kEntries), coral(kEntries), merged(kEntries) {
    const bool reef = spec.reef.enabled;
    for (int j = 0; j < kEntries; ++j) {
      const double xt = 5.0 * j / (kEntries - 1), x = xt - 3.0;
      rho[j] = float(sample_curve(spec.resistance, xt / 5.0));
      const double h0 = subsided_height_m(sample_curve(spec.profile, xt / 5.0), spec.subsidence, spec.heights);
      hsub[j] = float(reef ? shore_height_m(h0, xt, lagoon_depth_m, spec.reef) : h0);
      // With the reef, apply_reef grows the rim's coral in metres (its zones'
      // widths do not scale with the band): no coral from x̃ here.
      if (!spec.coral.enabled || reef) coral[j] = kNoCoral;
      else coral[j] = float(coral_height_m(x, spec.coral));
      merged[j] = spec.coral.enabled ? float(smax(hsub[j], coral[j], spec.smax_k)) : hsub[j];
    }
  }
};

// The wind's displacement on the (warp_grid + 1)² nodes, or an empty field
// when no stroke blows.
cv::Mat2f displacement_field(const IslandSpec& spec, const RenderOptions& opt, const OutlineTable& outlines,
                             const std::vector<float>& rho) {
  const bool warp = std::any_of(spec.wind.begin(), spec.wind.end(), [](const WindStroke& w) { return w.strength > 0; });
  if (!warp) return {};
  const int n = opt.warp_grid;
  const cv::Mat2f phi_coarse = wind_field(spec.wind, opt.wind_grid);
  cv::Mat2f phi(n + 1, n + 1);
  for (int r = 0; r <= n; ++r)
    for (int c = 0; c <= n; ++c)
      phi(r, c) = sample_nodes(phi_coarse, opt.wind_grid, -1.f + 2.f * c / n, 1.f - 2.f * r / n);
  return integrate_warp(phi, resistance_field(outlines, rho, opt.resistance_grid), spec.wind_substeps);
}

// Where each pixel's material came from: the displacement grid read
// bilinearly at the pixel centre. The weights are separable, so they are
// tabulated per column and per row.
class SourceGrid {
 public:
  SourceGrid(const cv::Mat2f& D, int W, int n) : D_(D), cell_(W), frac_(W) {
    for (int i = 0; i < W; ++i) {
      const float g = (2.f * i + 1.f) / (2.f * W) * n;  // pixel centre in grid units
      cell_[i] = std::min(static_cast<int>(g), n - 1);
      frac_[i] = g - cell_[i];
    }
  }

  // Row y's source coordinates in [-1, 1]² (y up).
  void row(int y, float* src_x, float* src_y) const {
    const int W = int(cell_.size());
    const float py = 1.f - (2.f * y + 1.f) / W;
    const cv::Vec2f* d0 = D_.empty() ? nullptr : D_.ptr<cv::Vec2f>(cell_[y]);
    const cv::Vec2f* d1 = D_.empty() ? nullptr : D_.ptr<cv::Vec2f>(cell_[y] + 1);
    const int* cell = cell_.data();
    const float* frac = frac_.data();
    const float b = frac[y];
    for (int x = 0; x < W; ++x) {
      const float px = -1.f + (2.f * x + 1.f) / W;
      float sx = px, sy = py;
      if (d0) {
        const int c = cell[x];
        const float a = frac[x];
        const cv::Vec2f top = d0[c] + a * (d0[c + 1] - d0[c]);
        const cv::Vec2f bot = d1[c] + a * (d1[c + 1] - d1[c]);
        sx += top[0] + b * (bot[0] - top[0]);
        sy += top[1] + b * (bot[1] - top[1]);
      }
      src_x[x] = sx;
      src_y[x] = sy;
    }
  }

 private:
  const cv::Mat2f& D_;
  std::vector<int> cell_;
  std::vector<float> frac_;
};

// Detail noise: the shared periodic tile, sampled at a seed-dependent offset
// and one of 8 orientations, in source coordinates so it moves with the wind.
class NoiseLookup {
 public:
  NoiseLookup(const DetailNoise& p, int W)
      : tile_(p.amplitude > 0 ? &NoiseTile::get(p.octaves) : nullptr),
        texels_(float(NoiseTile::kBaseCell / p.feature)),
        // Magnified (a texel wider than a pixel, e.g. above ~400² at the
        // default feature), the tile is read bicubically: bilinear kinks would
        // draw a grid of creases (docs/EROSION.md). At 256² (1.6 texels per
        // pixel) the look-up stays bilinear, so the training data does not change.
        magnified_(texels_ * 2.f / float(W) < 1.f) {
    Rng rng(p.seed, 0, "detail-noise-placement");
    u0_ = float(rng.uniform(0, NoiseTile::kSize));
    v0_ = float(rng.uniform(0, NoiseTile::kSize));
    orient_ = static_cast<int>(rng.uniform_int(0, 7));
  }

  bool on() const { return tile_ != nullptr; }
  // The noise in [-1, 1] at source point (sx, sy).
  float at(float sx, float sy) const {
    const float qa = (orient_ & 1) ? sy : sx, qb = (orient_ & 1) ? sx : sy;
    const float u = ((orient_ & 2) ? -qa : qa) * texels_ + u0_, v = ((orient_ & 4) ? -qb : qb) * texels_ + v0_;
    return magnified_ ? tile_->sample_cubic(u, v) : tile_->sample(u, v);
  }

 private:
  const NoiseTile* tile_;
  float texels_;
  bool magnified_;
  float u0_ = 0, v0_ = 0;
  int orient_ = 0;
};

// The first outline R₁ draws a ring round every young or uneroded island:
// x̃ (Eq. 1) is linear in r within each band, so dx̃/dr jumps where the wide
// core meets the narrower flank band (about 4× on the young-volcano preset)
// and the profile's slope jumps with it (a second difference of 4.6 m across
// R₁ at 1025² on 6 km, against ≤ 2.3 m anywhere else on the flank). Near
// x̃ = 1 the noise-free heights are blended with their own Gaussian blur,
// σ = kCoreRingSigma of the canvas width (23 m on 6 km), fully within
// kCoreRingInner of x̃ = 1 and fading out by kCoreRingOuter: the slope turns
// over ~100 m instead of one pixel. Labels and x̃ are untouched (the coast
// and every region stay where the outlines put them).
constexpr double kCoreRingSigma = 0.004;
constexpr float kCoreRingInner = 0.2f, kCoreRingOuter = 0.5f;
void soften_core_ring(cv::Mat1f& h, const cv::Mat1f& xt) {
  const double sigma = std::max(0.5, kCoreRingSigma * h.cols);
  cv::Mat1f blurred;
  cv::GaussianBlur(h, blurred, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
  for (int y = 0; y < h.rows; ++y) {
    float* hr = h.ptr<float>(y);
    const float* br = blurred.ptr<float>(y);
    const float* xr = xt.ptr<float>(y);
    for (int x = 0; x < h.cols; ++x) {
      const float d = std::fabs(xr[x] - 1.f);
      if (d >= kCoreRingOuter) continue;
      const float t = std::min(1.f, (kCoreRingOuter - d) / (kCoreRingOuter - kCoreRingInner));
      const float w = smoothstep(t);  // no kink where the blend begins
      hr[x] += w * (br[x] - hr[x]);
    }
  }
}

// With erosion, coral grows on the eroded volcano: the smooth maximum of
// each pixel and its coral height (also on the uneroded copy, if kept).
void grow_coral(IslandFields& out, const cv::Mat1f& coral_m, const SmoothMaxTable& smax_table) {
  for (int y = 0; y < out.height_m.rows; ++y) {
    float* h = out.height_m.ptr<float>(y);
    const float* c = coral_m.ptr<float>(y);
    for (int x = 0; x < out.height_m.cols; ++x) h[x] = smax_table(h[x], c[x]);
    if (!out.uneroded_m.empty()) {
      float* u = out.uneroded_m.ptr<float>(y);
      for (int x = 0; x < out.height_m.cols; ++x) u[x] = smax_table(u[x], c[x]);
    }
  }
}

// The shield before erosion (docs/EROSION.md "The shield"): a volcano is not a
// turned cone. Its lava builds broad ridges along two or three rift zones
// from the summit (Kīlauea's east and south-west rifts, Kohala's two) and
// lobes of flows between them; drainage divides follow the ridges and the
// largest basins form between them, where a radial cone drew equal valleys
// all round. The land's heights × (1 + a·F): F the rift ridges (von Mises
// bumps in azimuth round the canvas centre, κ = kRiftConcentration, growing
// from the summit outwards so no crease meets there) plus a 3-octave lobe
// noise, all drawn from the noise seed: a seed re-rolls the basins' layout,
// not only the grain. Smooth everywhere (sums, no max: no straight crease),
// multiplicative, so the 0 m coast stays where the outlines drew it.
constexpr double kRiftConcentration = 6;
constexpr int kMaxRifts = 3;
void shape_shield(cv::Mat1f& h, const DetailNoise& p) {
  Rng rng(p.seed, 0, "shield-rifts");
  const int rifts = 2 + int(rng.uniform_int(0, kMaxRifts - 2));
  // The first rift anywhere, the second roughly opposite (120–240° on), a third between.
  double azimuth[kMaxRifts];
  azimuth[0] = rng.uniform(0, 2 * CV_PI);
  azimuth[1] = azimuth[0] + rng.uniform(2 * CV_PI / 3, 4 * CV_PI / 3);
  azimuth[2] = azimuth[0] + rng.uniform(-CV_PI / 2, CV_PI / 2) + CV_PI / 2;
  const double strength[kMaxRifts] = {1.0, rng.uniform(0.6, 1.0), rng.uniform(0.3, 0.7)};
  const terrain::GradientNoise2 lobes(mix64(p.seed ^ 0x5417e1dull));
  const float off_x = float(rng.uniform(0, 64)), off_y = float(rng.uniform(0, 64));
  const int W = h.cols;
  const float a = float(p.shield), scale = float(2.0 / W / p.shield_feature);
  const double norm = std::exp(kRiftConcentration);
  for (int y = 0; y < W; ++y)
    for (int x = 0; x < W; ++x) {
      if (h(y, x) <= 0) continue;
      const double cx = 2.0 * (x + 0.5) / W - 1, cy = 1 - 2.0 * (y + 0.5) / W;
      const double r = std::hypot(cx, cy), theta = std::atan2(cy, cx);
      double ridge = 0;
      for (int k = 0; k < rifts; ++k) ridge += strength[k] * std::exp(kRiftConcentration * std::cos(theta - azimuth[k])) / norm;
      // From nothing at the summit to whole ridges a quarter-canvas out.
      const double grow = std::min(1.0, r / 0.25);
      const float f = float(grow * grow * (ridge - 0.35)) + lobes.fbm(float(x) * scale + off_x, float(y) * scale + off_y, 3);
      h(y, x) = std::max(h(y, x) * (1.f + a * f), std::min(h(y, x), terrain::kLandFloorM));
    }
}

// The prevailing wind, image axes (x right, y down): the strokes' unit
// tangents at their control points, each weighted by its stroke's strength
// (Eq. 2's S). A zero vector when there is no wind (or the strokes cancel).
cv::Vec2d prevailing_wind(const IslandSpec& spec) {
  cv::Vec2d w(0, 0);
  for (const auto& stroke : spec.wind)
    for (size_t i = 1; i < stroke.points.size(); ++i) {
      const double dx = stroke.points[i].x - stroke.points[i - 1].x, dy = stroke.points[i].y - stroke.points[i - 1].y;
      const double len = std::hypot(dx, dy);
      if (len > 0) w += stroke.strength * cv::Vec2d(dx / len, -dy / len);  // +y up on the canvas, down in the image
    }
  return w;
}

// The rain the erosion reads (terrain/rain.hpp), from the volcano's heights
// and the prevailing wind; empty without wind or rain.
terrain::RainFields rain_of(const IslandSpec& spec, const cv::Mat1f& volcano_m) {
  const cv::Vec2d wind = prevailing_wind(spec);
  if (!spec.rain.enabled || !(std::hypot(wind[0], wind[1]) > 1e-9)) return {};
  return terrain::rain_for_erosion(volcano_m, spec.world_size_m, wind, spec.rain);
}

}  // namespace

// The island in one pass over the pixels: each pixel's source point (the
// wind's warp), its parametric distance x̃ to the outlines, then height and
// label from the profile tables and the detail noise. With erosion, the
// volcano (h_sub + detail noise) is eroded on its own and coral grows after
// it (docs/EROSION.md): the pixel loop keeps the volcano, the coral height
// and the resistance apart, merged once the land has moved.
IslandFields generate(const IslandSpec& spec, const RenderOptions& opt) {
  validate(spec);
  check_render_options(opt);
  const int W = opt.size_px;
  const OutlineTable outlines(spec.outlines, spec.min_gap);
  const bool reef = spec.reef.enabled;
  const double lagoon_m = reef ? lagoon_depth_m(spec) : 0.0;
  const ProfileTables lut(spec, lagoon_m);
  const cv::Mat2f D = displacement_field(spec, opt, outlines, lut.rho);
  const SourceGrid source(D, W, opt.warp_grid);
  const NoiseLookup noise(spec.noise, W);
  const SmoothMaxTable smax_table(spec.smax_k);
  const bool noisy = noise.on(), eroded = spec.erosion.enabled, split = eroded || reef;
  const float amp = float(spec.noise.amplitude), lut_scale = lut.scale;
  const float *rho = lut.rho.data(), *hsub = lut.hsub.data(), *coral = lut.coral.data(), *merged = lut.merged.data();
  constexpr int kLast = ProfileTables::kEntries - 2;  // the last interval's first entry

  IslandFields out{cv::Mat1f(W, W), cv::Mat1f(W, W), cv::Mat1b(W, W), cv::Mat1f(), cv::Mat1f()};
  cv::Mat1f coral_m, rho_px;  // coral_m: the coral to grow on the eroded volcano (the reef grows its own)
  cv::Mat2f source_px;  // with the reef: each pixel's source point
  const bool coral_after = eroded && !reef && spec.coral.enabled;
  if (coral_after) coral_m.create(W, W);
  if (eroded) rho_px.create(W, W);
  if (reef) source_px.create(W, W);
  // Per row: the source points, then x̃ for the whole row on the CPU's
  // vector path, then the noise-free heights and labels; the heights get
  // their detail noise (and, without erosion or reef, their coral) once the
  // core's ring is softened.
  std::vector<float> src_x(W), src_y(W), xt_row(W);
  cv::Mat1f detail;  // 1 + a·n per pixel
  if (noisy) detail.create(W, W);
  for (int y = 0; y < W; ++y) {
    source.row(y, src_x.data(), src_y.data());
    outlines.xt_row(src_x.data(), src_y.data(), W, xt_row.data());
    float* hrow = out.height_m.ptr<float>(y);
    float* xrow = out.xt.ptr<float>(y);
    uint8_t* lrow = out.label.ptr<uint8_t>(y);
    for (int x = 0; x < W; ++x) {
      const float xt = xt_row[x];
      const float g = xt * lut_scale;
      const int j = std::min(static_cast<int>(g), kLast);
      const float f = g - j;
      float h;
      if (!split && !noisy) {
        h = merged[j] + f * (merged[j + 1] - merged[j]);
      } else {
        h = hsub[j] + f * (hsub[j + 1] - hsub[j]);
        if (noisy) detail(y, x) = 1.f + amp * noise.at(src_x[x], src_y[x]);
        if (coral_after) coral_m(y, x) = coral[j] + f * (coral[j + 1] - coral[j]);
        if (eroded) rho_px(y, x) = rho[j] + f * (rho[j + 1] - rho[j]);
      }
      if (reef) source_px(y, x) = cv::Vec2f(src_x[x], src_y[x]);
      hrow[x] = h;
      xrow[x] = xt;
      lrow[x] = static_cast<uint8_t>(std::min(static_cast<int>(xt), 4));
    }
  }
  soften_core_ring(out.height_m, out.xt);
  if (noisy) out.height_m = out.height_m.mul(detail);
  if (!split && noisy && spec.coral.enabled)
    for (int y = 0; y < W; ++y)
      for (int x = 0; x < W; ++x) {
        const float g = out.xt(y, x) * lut_scale;
        const int j = std::min(static_cast<int>(g), kLast);
        const float c = coral[j] + (g - j) * (coral[j + 1] - coral[j]);
        out.height_m(y, x) = smax_table(out.height_m(y, x), c);
      }
  if (eroded) {
    if (spec.noise.shield > 0) shape_shield(out.height_m, spec.noise);
    if (opt.keep_uneroded) out.uneroded_m = out.height_m.clone();
    terrain::RainFields rain = rain_of(spec, out.height_m);
    out.height_m = terrain::erode_island(out.height_m, rho_px, spec.world_size_m, spec.noise.seed, spec.erosion,
                                         rain.runoff_rel);
    out.rain_mm_yr = std::move(rain.mm_yr);
    if (coral_after) grow_coral(out, coral_m, smax_table);
  }
  if (reef) {
    const ReefPlan plan = plan_reef(spec, outlines);
    const ReefInputs in{out.xt, source_px};
    apply_reef(out.height_m, &out.label, in, spec, outlines, plan);
    if (!out.uneroded_m.empty()) apply_reef(out.uneroded_m, nullptr, in, spec, outlines, plan);
  }
  return out;
}

}  // namespace reefgen::procgen
