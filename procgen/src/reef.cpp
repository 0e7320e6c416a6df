#include "reefgen/procgen/reef.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "reefgen/error.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/ramp.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/terrain/noise.hpp"
#include "reefgen/terrain/patch_reefs.hpp"

namespace reefgen::procgen {

namespace {

// Patch reefs rise to their full height over this distance inside R₃ (m):
// about a knoll's half-width, so its side at the rim is no steeper than its others.
constexpr double kKnollRimMarginM = 120;

inline double ease(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return smoothstep(t);
}

// Wraps an angle difference into (−π, π].
inline double wrap_angle(double a) {
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a < 0) a += 2.0 * M_PI;
  return a - M_PI;
}

// Area inside outline R_3 (the lagoon's outer border), canvas units².
double lagoon_area_canvas(const OutlineTable& outlines) {
  constexpr int kSteps = 720;
  double a = 0;
  for (int i = 0; i < kSteps; ++i) {
    const double r = outlines.radii(2.0 * M_PI * i / kSteps)[2];
    a += 0.5 * r * r * (2.0 * M_PI / kSteps);
  }
  return a;
}

double canvas_to_m(const IslandSpec& spec) { return spec.world_size_m / 2.0; }

// Unit vector towards where the wind comes from: minus the strength-weighted
// mean direction of the strokes; without wind, a direction drawn from the seed.
std::array<double, 2> windward_direction(const IslandSpec& spec) {
  double wx = 0, wy = 0;
  for (const auto& w : spec.wind) {
    if (w.points.size() < 2) continue;
    const double dx = w.points.back().x - w.points.front().x, dy = w.points.back().y - w.points.front().y;
    const double l = std::hypot(dx, dy);
    if (l > 0) wx -= w.strength * dx / l, wy -= w.strength * dy / l;
  }
  const double l = std::hypot(wx, wy);
  if (l > 1e-9) return {wx / l, wy / l};
  Rng rng(spec.noise.seed, 0, "reef-windward");
  const double a = rng.uniform(0, 2.0 * M_PI);
  return {std::cos(a), std::sin(a)};
}

ReefPlan::Pass pass_from_curve(const std::vector<Vec2>& points, double width_m, double depth_m, double to_canvas) {
  ReefPlan::Pass p;
  // 8 samples per control interval for a curve of a few points, fewer as it
  // has more: at most ~512 segments a pass.
  const auto poly = sample_open_catmull_rom(points, std::clamp(512 / int(points.size()), 1, 8));
  for (size_t i = 0; i + 1 < poly.size(); ++i)
    p.segs.push_back({float(poly[i].x), float(poly[i].y), float(poly[i + 1].x), float(poly[i + 1].y)});
  p.half_width = 0.5 * width_m * to_canvas;
  p.depth_m = depth_m;
  // The widest the cut gets (apply_reef: ×1.6 seaward, ×1.2 roughened).
  const float pad = float(2.0 * p.half_width);
  auto grow = [pad](std::array<float, 4>& b, const std::array<float, 4>& g) {
    b[0] = std::min({b[0], g[0] - pad, g[2] - pad});
    b[1] = std::min({b[1], g[1] - pad, g[3] - pad});
    b[2] = std::max({b[2], g[0] + pad, g[2] + pad});
    b[3] = std::max({b[3], g[1] + pad, g[3] + pad});
  };
  p.box = {1e30f, 1e30f, -1e30f, -1e30f};
  for (size_t i = 0; i < p.segs.size(); ++i) {
    if (i % kPassChunk == 0) p.chunk_box.push_back({1e30f, 1e30f, -1e30f, -1e30f});
    grow(p.chunk_box.back(), p.segs[i]);
    grow(p.box, p.segs[i]);
  }
  return p;
}

// Random passes: on the leeward rim (within ±60° of leeward), where lagoons
// drain (Purdy & Winterer: passes cut the rim, often leeward), each a short
// radial cut across the reef from the lagoon to the fore reef.
void add_random_passes(ReefPlan& plan, const IslandSpec& spec, const OutlineTable& outlines, double to_canvas) {
  Rng rng(spec.noise.seed, 0, "reef-passes");
  const double leeward = std::atan2(-plan.windward[1], -plan.windward[0]);
  for (int k = 0; k < spec.reef.random_passes; ++k) {
    const double th = leeward + rng.uniform(-M_PI / 3, M_PI / 3);
    const auto R = outlines.radii(th);
    const double r0 = R[2] - 0.03, r1 = R[3] + 0.03;
    // As deep as the lagoon's edge at least, so the pass joins lagoon and sea.
    const double width_m = rng.uniform(100, 260), depth_m = std::max(rng.uniform(8, 20), kBackReefShare * plan.depth_m);
    // Four points across the rim, each pushed sideways: a channel that winds
    // but crosses the rim (a wider push ran it along a wide rim).
    std::vector<Vec2> pts;
    for (int i = 0; i < 4; ++i) {
      const double r = r0 + (r1 - r0) * i / 3.0, a = th + rng.uniform(-0.8, 0.8) * width_m * to_canvas / r;
      pts.push_back({r * std::cos(a), r * std::sin(a)});
    }
    plan.passes.push_back(pass_from_curve(pts, width_m, depth_m, to_canvas));
  }
}

// The angle of a pass's middle, seen from the canvas centre.
double pass_angle(const ReefPlan::Pass& p) {
  const auto& s = p.segs[p.segs.size() / 2];
  return std::atan2(0.5 * (s[1] + s[3]), 0.5 * (s[0] + s[2]));
}

// A motu's top falls from its height at the ocean edge (the coral-rubble
// storm ridge) by this share of it per half-width towards the lagoon (the
// sand slopes down to it; Stoddart & Steers 1977; motu 1–4 m high): ~0.6 %
// across the crown of a 1.5 m, 200 m wide islet, more on higher ones.
constexpr double kMotuLean = 0.4;
// The motu loop looks this many half-widths out (the apron is below the
// reef by then); an islet's edge is roughened by up to kMotuEdgeNoise of its
// distance.
constexpr double kMotuApronReach = 3.0, kMotuEdgeNoise = 0.15;

// Relief of the crest and the flat along the rim (m, amplitude of a noise of
// the given feature size in m): reef flats and crests are not level (One
// Tree Reef: 3.5 % of the −2…+1 m band within 1 cm of one height).
constexpr double kCrestReliefM = 0.25, kCrestReliefFeatureM = 200;
constexpr double kFlatReliefM = 0.7, kFlatReliefFeatureM = 120;

// A motu sits on the flat's lagoonward part, with this much flat seaward of
// it (m; Johnson & Ortiz 2023: 184 ± 93 m in front of large motu), and is
// never narrower than kMinMotuWidthM (less flat than that: none there).
constexpr double kMotuSeawardFlatM = 150, kMinMotuWidthM = 60;
// Beyond its edge a motu's sand apron descends at this slope (tan 20°) until
// it meets the reef: no wall into the lagoon or onto the flat.
constexpr double kMotuApronSlope = 0.36;

// The cosine of the angle between the canvas direction th and windward.
double facing_wind(const ReefPlan& plan, double th) { return std::cos(th) * plan.windward[0] + std::sin(th) * plan.windward[1]; }

// The half-width (m) a motu has room for at angle th: half the flat that is
// left lagoonward of kMotuSeawardFlatM.
double motu_half_width_room_m(const ReefPlan& plan, const IslandSpec& spec, const OutlineTable& outlines, double th) {
  const auto R = outlines.radii(th);
  const RimWidths w = rim_widths_m((R[3] - R[2]) * canvas_to_m(spec), facing_wind(plan, th), spec.reef);
  return 0.5 * (w.flat - kMotuSeawardFlatM);
}

// Random motu: sand islets on the reef flat, 150–1200 m long and 150–400 m
// wide (Johnson & Ortiz, 154 atolls: motu 263 ± 210 m wide), 1.5–3.5 m high,
// kept away from the passes; fewer on young fringing reefs.
void add_random_motu(ReefPlan& plan, const IslandSpec& spec, const OutlineTable& outlines, double to_canvas) {
  Rng rng(spec.noise.seed, 0, "reef-motu");
  const int count = int(std::lround(spec.reef.random_motu * std::min(1.0, spec.subsidence / 0.2)));
  for (int k = 0; k < count; ++k) {
    const double th = rng.uniform(-M_PI, M_PI);
    const double len_m = rng.uniform(150, 1200), wid_m = rng.uniform(150, 400), top = rng.uniform(1.5, 3.5);
    const bool near_pass = std::any_of(plan.passes.begin(), plan.passes.end(), [&](const ReefPlan::Pass& p) {
      return std::fabs(wrap_angle(th - pass_angle(p))) < 0.15;
    });
    if (near_pass) continue;
    ReefPlan::Islet m;
    m.theta = th;
    m.half_wid = std::min(0.5 * wid_m, motu_half_width_room_m(plan, spec, outlines, th)) * to_canvas;
    if (m.half_wid < 0.5 * kMinMotuWidthM * to_canvas) continue;  // no room on this stretch of flat
    m.half_len = 0.5 * len_m * to_canvas;
    m.height_m = top;
    plan.motu.push_back(m);
  }
}

}  // namespace

double lagoon_depth_for_area_m(double area_km2) {
  return std::clamp(18.0 + 12.0 * std::log10(std::max(area_km2, 1e-6)), 8.0, 90.0);
}

double lagoon_depth_m(const IslandSpec& spec) {
  const auto& r = spec.reef;
  double full = r.lagoon_depth_m;
  if (full <= 0) {
    const OutlineTable outlines(spec.outlines, spec.min_gap);
    const double m = canvas_to_m(spec);
    full = lagoon_depth_for_area_m(lagoon_area_canvas(outlines) * m * m * 1e-6);
  }
  const double age = r.young_lagoon_share + (1.0 - r.young_lagoon_share) * ease(spec.subsidence / kBarrierLambda);
  return full * age;
}

double shore_height_m(double h_m, double xt, double depth_m, const ReefParams& r) {
  if (h_m > 0) h_m *= 1.0 - ease((xt - r.coast_begin) / (2.0 - r.coast_begin));
  if (xt > 2.0) h_m = std::min(h_m, -depth_m * ease((xt - 2.0) / r.shoreface));
  return h_m;
}

RimWidths rim_widths_m(double band_m, double facing, const ReefParams& r) {
  RimWidths w{r.fore_reef_m + kDropOffWidthM, r.crest_width_m, r.flat_width_m * (1.0 + r.windward_flat_gain * std::clamp(facing, -1.0, 1.0)),
              kMinBackReefM};
  const double others = w.fore + w.crest + w.back;
  if (others + w.flat <= band_m) {
    w.back = band_m - w.fore - w.crest - w.flat;
    return w;
  }
  w.flat = std::max(0.0, band_m - others);
  const double k = band_m / (others + w.flat);
  if (k < 1) w.fore *= k, w.crest *= k, w.flat *= k, w.back *= k;
  return w;
}

double rim_height_m(double s, const RimWidths& w, const CoralParams& c, double back_m, const ReefParams& r,
                    double crest_relief_m, double flat_relief_m) {
  const double crest = c.crest_m + crest_relief_m, flat = c.flat_m + flat_relief_m;
  if (s <= w.fore) {
    const double drop = w.fore * kDropOffWidthM / (r.fore_reef_m + kDropOffWidthM), terrace = w.fore - drop;
    const double rise = r.fore_reef_depth_m + crest;  // the terrace's, foot to crest
    if (s >= drop) return crest - rise * std::pow(1.0 - (s - drop) / terrace, 1.5);
    // The drop-off: its slope where the terrace ends (1.5 · rise / terrace), then steeper to R₄.
    const double fall = rim_edge_depth_m(r) - r.fore_reef_depth_m, u = (drop - std::max(s, 0.0)) / drop;
    const double a = std::min(1.0, 1.5 * rise / terrace * drop / fall);
    return -r.fore_reef_depth_m - fall * (a * u + (1.0 - a) * std::pow(u, 1.5));
  }
  s -= w.fore;
  if (s <= w.crest) return crest;
  s -= w.crest;
  if (w.flat <= 0) return crest + (back_m - crest) * ease(s / w.back);
  if (s <= w.flat) {
    // The flat turns up into the crest over its first quarter.
    const double t = std::max(0.0, 1.0 - s / (0.25 * w.flat));
    return flat + (crest - flat) * t * t * t;
  }
  s -= w.flat;
  return flat + (back_m - flat) * ease(s / w.back);
}

ReefPlan plan_reef(const IslandSpec& spec, const OutlineTable& outlines) {
  ReefPlan plan;
  plan.depth_m = lagoon_depth_m(spec);
  plan.windward = windward_direction(spec);
  const double to_canvas = 1.0 / canvas_to_m(spec);
  for (const auto& p : spec.reef.passes) plan.passes.push_back(pass_from_curve(p.points, p.width_m, p.depth_m, to_canvas));
  add_random_passes(plan, spec, outlines, to_canvas);
  for (const auto& m : spec.reef.motu) {
    ReefPlan::Islet i;
    i.theta = m.angle_deg * M_PI / 180.0;
    i.half_len = 0.5 * m.length_m * to_canvas;
    // Never wider than the flat has room for (but kept, at its least width, where it has none).
    i.half_wid = std::min(0.5 * m.width_m, std::max(0.5 * kMinMotuWidthM, motu_half_width_room_m(plan, spec, outlines, i.theta))) * to_canvas;
    i.height_m = m.height_m;
    plan.motu.push_back(i);
  }
  add_random_motu(plan, spec, outlines, to_canvas);
  return plan;
}

namespace {

// Distance (canvas units) from a point to a pass's centre line, or 1e30
// when the point is outside every chunk's box (farther than the cut reaches).
float pass_distance(const ReefPlan::Pass& p, float x, float y) {
  float best = 1e30f;
  for (size_t c = 0; c < p.chunk_box.size(); ++c) {
    const auto& b = p.chunk_box[c];
    if (x < b[0] || y < b[1] || x > b[2] || y > b[3]) continue;
    const size_t end = std::min(p.segs.size(), (c + 1) * size_t(kPassChunk));
    for (size_t i = c * kPassChunk; i < end; ++i) {
    const auto& s = p.segs[i];
    const float dx = s[2] - s[0], dy = s[3] - s[1], wx = x - s[0], wy = y - s[1];
    const float l2 = dx * dx + dy * dy;
    const float t = l2 > 0 ? std::clamp((wx * dx + wy * dy) / l2, 0.f, 1.f) : 0.f;
    const float ex = wx - t * dx, ey = wy - t * dy;
    best = std::min(best, ex * ex + ey * ey);
    }
  }
  return best >= 1e30f ? 1e30f : std::sqrt(best);
}

// A low-frequency noise tabulated on a (kTableSide + 1)² grid over
// ±kTableExtent canvas units (cells of ~23 m at the default 6 km canvas) and
// read bilinearly: the sea floor's relief has features of 1500 m, so this
// replaces three octaves of gradient noise per abyss cell at no visible cost.
// Nodes are evaluated the first time a look-up reads one of them, kNoiseTableBlock
// neighbours of a row at once on the CPU's vector path (NaN until then): at
// 256² an island's abyss touches a tenth of the 513² nodes, and building them
// all cost more than the rest of the reef (docs/BENCHMARKS.md). The values
// are the full table's, whatever the order of the look-ups. F(xs, ys, n, out)
// evaluates n nodes at canvas points (xs, ys).
constexpr int kNoiseTableBlock = 16;
template <class F>
class NoiseTable {
 public:
  static constexpr int kTableSide = 512;
  static constexpr float kTableExtent = 2.f;
  explicit NoiseTable(F f) : f_(std::move(f)), t_(kTableSide + 1, kTableSide + 1, std::numeric_limits<float>::quiet_NaN()) {}
  float at(float x, float y) {
    const float gx = std::clamp((x + kTableExtent) / (2.f * kTableExtent) * kTableSide, 0.f, float(kTableSide) - 1e-3f);
    const float gy = std::clamp((y + kTableExtent) / (2.f * kTableExtent) * kTableSide, 0.f, float(kTableSide) - 1e-3f);
    const int ix = int(gx), iy = int(gy);
    const float fx = gx - ix, fy = gy - iy;
    const float a = node(iy, ix) + fx * (node(iy, ix + 1) - node(iy, ix));
    const float b = node(iy + 1, ix) + fx * (node(iy + 1, ix + 1) - node(iy + 1, ix));
    return a + fy * (b - a);
  }

 private:
  static float coordinate(int i) { return -kTableExtent + 2.f * kTableExtent * i / kTableSide; }
  float node(int r, int c) {
    float& v = t_(r, c);
    if (std::isnan(v)) fill_block(r, c - c % kNoiseTableBlock);
    return v;
  }
  void fill_block(int r, int c0) {
    const int n = std::min(kNoiseTableBlock, kTableSide + 1 - c0);
    float xs[kNoiseTableBlock], ys[kNoiseTableBlock];
    for (int i = 0; i < n; ++i) xs[i] = coordinate(c0 + i), ys[i] = coordinate(r);
    f_(xs, ys, n, &t_(r, c0));
  }
  F f_;
  cv::Mat1f t_;
};

// Step 1's two noises for the cells of one row that step 1 reads, read at
// once on the CPU's vector path (GradientNoise2::fbm_n): the lagoon floor's
// relief (2 octaves, 600 m features) and the patch reefs' (3 octaves,
// kPatchCellM), in the order of the cells.
constexpr double kLagoonReliefFeatureM = 600;
struct LagoonNoiseRow {
  std::vector<float> u, v, pu, pv, relief, patch;
  void clear() { u.clear(), v.clear(), pu.clear(), pv.clear(); }
  void add(double sx, double sy, double to_m) {
    u.push_back(float(sx * to_m / kLagoonReliefFeatureM)), v.push_back(float(sy * to_m / kLagoonReliefFeatureM));
    pu.push_back(float(sx * to_m / terrain::kPatchCellM)), pv.push_back(float(sy * to_m / terrain::kPatchCellM));
  }
  void read(const terrain::GradientNoise2& noise, const terrain::GradientNoise2& patch_noise, bool patches) {
    const int n = int(u.size());
    relief.resize(n), patch.resize(n);
    noise.fbm_n(u.data(), v.data(), n, 2, relief.data());
    if (patches) patch_noise.fbm_n(pu.data(), pv.data(), n, 3, patch.data());
  }
};

}  // namespace

// Coral height (m) off the rim: far below any ground, so Eq. 9's smooth
// maximum returns the ground unchanged.
constexpr double kNoCoralM = -1e4;

// Long: the reef's six numbered steps (lagoon floor, passes, coral growth,
// motu, spur-and-groove, flank) run in one pass per cell over the distance
// fields computed at the top; each step is marked.
void apply_reef(cv::Mat1f& height_m, cv::Mat1b* label, const ReefInputs& in, const IslandSpec& spec,
                const OutlineTable& outlines, const ReefPlan& plan) {
  const auto& c = spec.coral;
  const auto& rp = spec.reef;
  const int W = height_m.cols;
  const double to_m = canvas_to_m(spec), mpp = spec.world_size_m / W;
  const double D = plan.depth_m;
  const SmoothMaxTable smax_table(spec.smax_k);
  const terrain::GradientNoise2 noise(derive_seed(spec.noise.seed, 0, "reef-noise"));
  const terrain::GradientNoise2 patch_noise(derive_seed(spec.noise.seed, 0, "reef-patches"));
  // Spur-and-groove: a whole number of periods round the mean reef outline,
  // faded out below 3 px a period (it would alias into moiré).
  double mean_reef_r = 0;
  for (int i = 0; i < 64; ++i) mean_reef_r += outlines.radii(2.0 * M_PI * i / 64)[3] / 64;
  const double grooves_round = std::max(1.0, std::round(2.0 * M_PI * mean_reef_r * to_m / rp.groove_spacing_m));
  const double groove_fade = std::clamp((rp.groove_spacing_m / mpp - 3.0) / 3.0, 0.0, 1.0);
  const double groove_amp = rp.groove_amplitude_m * groove_fade;
  const double floor_m = spec.heights.floor_m;
  NoiseTable abyss_relief([&](const float* xs, const float* ys, int n, float* out) {
    float u[kNoiseTableBlock], v[kNoiseTableBlock];
    for (int i = 0; i < n; ++i) u[i] = float(xs[i] * to_m / kAbyssReliefFeatureM), v[i] = float(ys[i] * to_m / kAbyssReliefFeatureM);
    noise.fbm_n(u, v, n, 3, out);
  });
  const double back_m = -kBackReefShare * D;
  // Step 1 reads ground below −0.3 m short of the reef flat: it only ever
  // raises such ground, so land and shallows skip its noise.
  const auto lagoon_step = [&](double xr, double g) { return xr < c.flat_begin && g < -0.3; };
  const bool patches = rp.patch_reefs > 0 && D > 1;
  LagoonNoiseRow lagoon_noise;

  for (int y = 0; y < W; ++y) {
    float* h = height_m.ptr<float>(y);
    const float* xtr = in.xt.ptr<float>(y);
    const cv::Vec2f* src = in.source.ptr<cv::Vec2f>(y);
    uint8_t* lab = label ? label->ptr<uint8_t>(y) : nullptr;
    lagoon_noise.clear();
    for (int x = 0; x < W; ++x)
      if (lagoon_step(double(xtr[x]) - 3.0, h[x])) lagoon_noise.add(src[x][0], src[x][1], to_m);
    lagoon_noise.read(noise, patch_noise, patches);
    int lagoon_cell = 0;
    for (int x = 0; x < W; ++x) {
      const double sx = src[x][0], sy = src[x][1], xt = xtr[x], xr = xt - 3.0;
      // The cell's polar position and the outline radii at its angle, worked
      // out only where a step reads them (most land and lagoon cells read none).
      double r = 0, th = 0;
      std::array<double, 5> R{};
      bool polar = false;
      const auto need_polar = [&] {
        if (polar) return;
        r = std::sqrt(sx * sx + sy * sy), th = std::atan2(sy, sx), R = outlines.radii(th), polar = true;
      };
      double g = h[x];
      // The lagoon floor's height here (without step 1: its edge's): the
      // rim's back-reef slope ends on it, so no step where the rim meets the lagoon.
      double lagoon_floor = back_m;
      // 1. Lagoon floor: a basin deepest in the middle (q = 0) and 0.75 D at
      // the back reef, with low relief and patch reefs (their noises read
      // for the row above).
      if (lagoon_step(xr, g)) {
        need_polar();
        const int k = lagoon_cell++;
        const double q = std::min(1.0, r / R[2]);
        double F = -D * (kBackReefShare + (1.0 - kBackReefShare) * (1.0 - q * q)) + 0.08 * D * lagoon_noise.relief[k];
        // Patch reefs grow in the lagoon, not under the rim (a knoll's top
        // near the flat's height, merged by Eq. 9, stood above the sea), and
        // rise in over kKnollRimMarginM inside R₃: cut off at R₃ a knoll
        // stood as a 17 m wall over the back reef's toe (75° at 2049²).
        const double inside_m = (R[2] - r) * to_m;
        if (patches && xr < 0.0 && inside_m > 0) {
          const double knoll = terrain::patch_reef_from_fbm_m(patch_noise, lagoon_noise.pu[k], lagoon_noise.pv[k],
                                                              lagoon_noise.patch[k], D, rp.patch_reefs);
          if (knoll > F) F += ease(inside_m / kKnollRimMarginM) * (knoll - F);
        }
        lagoon_floor = std::min(F, -0.3);
        g = std::max(g, lagoon_floor);
      }
      // The rim's coral between R₃ and R₄, zoned in metres from R₄ inward
      // (docs/REEF.md "Reef proportions"); its crest and flat have relief
      // along the rim (no dead-level planes). s_m < 0 off the rim.
      double coral = kNoCoralM, s_m = -1;
      RimWidths rim{};
      bool rim_known = false;
      const auto need_rim = [&] {
        if (rim_known) return;
        need_polar();
        rim = rim_widths_m((R[3] - R[2]) * to_m, facing_wind(plan, th), rp), rim_known = true;
      };
      if (c.enabled && xr >= 0.0 && xr <= 1.0) {
        need_rim();
        s_m = (1.0 - xr) * (R[3] - R[2]) * to_m;
        const double crest_relief = kCrestReliefM * noise.perlin(float(sx * to_m / kCrestReliefFeatureM) + 31.7f,
                                                                 float(sy * to_m / kCrestReliefFeatureM));
        const double flat_relief = kFlatReliefM * noise.fbm(float(sx * to_m / kFlatReliefFeatureM) - 13.1f,
                                                            float(sy * to_m / kFlatReliefFeatureM) + 5.3f, 2);
        // The back-reef slope ends 3/k under the lagoon floor: where coral
        // and ground are equal Eq. 9's smooth maximum stands 1/(2k) above
        // both (1 m at the default k), which drew a ridge and a step along
        // the lagoon's edge; 3/k under, it adds 0.015 m.
        coral = rim_height_m(s_m, rim, c, lagoon_floor - 3.0 / spec.smax_k, rp, crest_relief, flat_relief);
      }
      // 2. Passes cut the coral down to their floor.
      bool in_pass = false;
      double pass_cut = 0;  // the strongest cut here, [0, 1]
      if (xr > -0.3 && xr < 1.0)
        for (const auto& p : plan.passes) {
          if (sx < p.box[0] || sy < p.box[1] || sx > p.box[2] || sy > p.box[3]) continue;
          // Wider seaward (the channel fans out over the fore reef), with
          // sloping walls (the cut deepens over its whole half-width) and
          // edges roughened along the channel.
          const double hw = p.half_width * (1.0 + 0.6 * ease(xr)) *
                            (1.0 + 0.2 * noise.perlin(float(sx * to_m / 90), float(sy * to_m / 90)));
          const double d = pass_distance(p, float(sx), float(sy));
          if (d >= hw) continue;
          const double m = ease(1.25 * (1.0 - d / hw));
          coral += m * (std::min(coral, -p.depth_m) - coral);
          g = std::min(g, g + m * (std::min(g, -p.depth_m) - g));
          in_pass = in_pass || m > 0.5;
          pass_cut = std::max(pass_cut, m);
        }
      // 3. Coral growth on the ground (Eq. 9) — but a pass's floor is the cut
      // surface, not a merge: where coral and ground are both cut to it the
      // smooth maximum stood 1/(2k) (1 m) above it, with a step where the
      // ground dipped below the floor. Blended by the cut's strength.
      {
        const double merged = smax_table(float(g), float(coral)), hard = std::max(g, coral);
        g = hard + (1.0 - pass_cut) * (merged - hard);
      }
      if (lab && in_pass && s_m >= rim.fore) lab[x] = kLagoon;
      // 4. Motu on the reef flat's lagoonward part, their edges roughened
      // along the rim, their aprons sloping down to the reef around them.
      if (xr > -0.2 && xr < 1.0 && !in_pass)
        for (const auto& m : plan.motu) {
          need_rim();
          const double rc = R[3] - (rim.fore + rim.crest + kMotuSeawardFlatM) / to_m - m.half_wid;
          const double u = wrap_angle(th - m.theta) * rc / m.half_len, v = (r - rc) / m.half_wid;
          double d = std::hypot(u, v);
          if (d >= kMotuApronReach) continue;
          // Past the islet its apron only raises ground that lies below it:
          // where even the roughest edge (d × (1 − kMotuEdgeNoise)) leaves
          // the apron under the ground, nothing changes and the noises are skipped.
          const double d_least = d * (1.0 - kMotuEdgeNoise);
          if (d_least > 1.0 && -0.6 - (d_least - 1.0) * m.half_wid * to_m * kMotuApronSlope <= g) continue;
          // Noise read at the cell's position, not its angle: the angle
          // jumps by 2π west of the centre and drew a seam across a motu there.
          d *= 1.0 + kMotuEdgeNoise * noise.perlin(float(sx * to_m / 120 + m.theta * 7), float(sy * to_m / 120));
          // The top leans from a storm ridge on the ocean side (v > 0) down to
          // the lagoon: a dead-flat top read as a filled, straight flat channel.
          // Along the islet the ridge rises and falls (±15 % over ~150 m): its
          // crest line is not level either.
          const double along_ridge = 1.0 + 0.15 * noise.perlin(float(sx * to_m / 150), float(sy * to_m / 150 + m.theta * 3 + 1.7));
          const double crown_m = m.height_m * (1.0 - kMotuLean * (1.0 - std::clamp(v, -1.0, 1.0))) * along_ridge;
          const double top = d < 1.0 ? -0.6 + (crown_m + 0.6) * ease((1.0 - d) / 0.45)
                                     : -0.6 - (d - 1.0) * m.half_wid * to_m * kMotuApronSlope;
          if (top > g) g = top;
          if (lab && top > 0.5) lab[x] = kBeach;  // above the crest: the islet, not the reef
        }
      // 5. Spur-and-groove: grooves perpendicular to the crest, 0.5 m to
      // groove_depth_m deep, on the windward side.
      const bool seaward_of_crest = xt >= 4.0 || (s_m >= 0 && s_m < rim.fore);
      if (groove_amp > 0 && seaward_of_crest && g < -0.5 && g > -rp.groove_depth_m) {
        need_polar();
        const double ww = ease(2.0 * facing_wind(plan, th) + 0.5);
        const double along = th * grooves_round;
        // The noises are read round a circle (the angle jumps by 2π west of
        // the centre, and a noise of it drew a seam in the grooves there).
        // The phase wanders by up to ~2 periods over ~12 and the relief and
        // the grooves' reach down the slope vary from spur to spur (a
        // smaller wander drew a comb of equal teeth at 70 m spacing).
        const double rho12 = grooves_round / 12.0, rho5 = grooves_round / 5.0;
        const double phase = along / (2.0 * M_PI) +
                             1.6 * noise.perlin(float(rho12 * std::cos(th)), float(rho12 * std::sin(th) + 3.5));
        const double spur = noise.perlin(float(rho5 * std::cos(th)), float(rho5 * std::sin(th) + 7.25));
        const double relief = 0.55 + 0.45 * spur;
        const double dg = -g, reach = rp.groove_depth_m * (0.75 + 0.25 * spur);
        const double wd = ease((dg - 0.5) / 2.0) * (1.0 - ease((dg - 0.6 * reach) / (0.4 * reach)));
        g += groove_amp * relief * ww * wd * std::cos(2.0 * M_PI * phase);
      }
      // 6. Beyond the rim the drop-off and the flank descend from the
      // terrace's foot towards the floor, e-folding over abyss_decay_m (35°
      // at the top by default, relaxing with depth), with relief: never a
      // flat plane.
      if (xt >= 4.0) {
        need_polar();
        const double d = std::max(0.0, r - R[3]) * to_m;
        const double n = abyss_relief.at(float(sx), float(sy));
        g = std::max(g, flank_height_m(d, floor_m, -rim_edge_depth_m(rp), rp.abyss_decay_m, rp.abyss_relief_m, n));
      }
      h[x] = float(g);
    }
  }
}

}  // namespace reefgen::procgen
