#include "reefgen/terrain/erosion.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/interrupt.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/terrain/drainage.hpp"
#include "reefgen/terrain/eroders.hpp"
#include "reefgen/terrain/flow.hpp"
#include "reefgen/terrain/noise.hpp"
#include "reefgen/terrain/pits.hpp"
#include "reefgen/wide_blur.hpp"

namespace reefgen::terrain {

using nlohmann::json;

void to_json(json& j, const ErosionParams& p) { j = params_json(p); }

ErosionParams matured(const ErosionParams& p, double maturity) {
  ErosionParams e = p;
  e.duration_yr *= maturity;
  e.steps = std::max(e.steps, int(std::lround(e.steps * std::sqrt(maturity))));
  e.channel_head_m2 = std::max(e.channel_head_m2, kMaturedChannelHeadM2);
  // The trunk basins take their time while the island is young; an older
  // island's extra time goes to the base grid, which deepens valleys into
  // them (the trunk's whole time × 5 planed a Kauaʻi-aged flank to a plain).
  if (maturity > 1) e.trunk_share = p.trunk_share / maturity;
  if (maturity > 1) e.diffusivity = p.diffusivity / maturity;
  return e;
}

ErosionParams scaled_to_canvas(const ErosionParams& p, double world_size_m, int out_px) {
  ErosionParams e = p;
  const double s = world_size_m / kReferenceCanvasM;
  if (s == 1) return e;
  e.base_px = std::clamp(int(std::lround(p.base_px * s)), std::min(16, out_px), std::max(out_px, 1));
  if (p.trunk_px > 0) e.trunk_px = std::clamp(int(std::lround(p.trunk_px * s)), std::min(16, out_px), std::max(out_px, 1));
  e.k_fluvial = p.k_fluvial * std::pow(s, 1 - 2 * p.m_area);
  return e;
}

ErosionParams erosion_params_from_json(const json& j, const std::string& origin) {
  return params_from_json<ErosionParams>(j, origin, "docs/EROSION.md", "erosion.");
}

cv::Mat1f erodibility_map(const cv::Mat1f& resistance, uint64_t seed, const ErosionParams& p) {
  const int H = resistance.rows, W = resistance.cols;
  const float amp = static_cast<float>(p.noise_amplitude), hard = static_cast<float>(p.hard_erodibility);
  // The modulation has about four features across the canvas: evaluated on at
  // most 128² nodes and interpolated (per-cell fBm was 0.5 s at 4097²).
  cv::Mat1f mod(H, W, 0.f);
  if (amp > 0) {
    const GradientNoise2 noise(seed);
    const int n = std::min({128, H, W});
    cv::Mat1f coarse(n, n);
    std::vector<float> u(n), v(n);
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) u[x] = 4.f * (x + 0.5f) / n + 0.37f, v[x] = 4.f * (y + 0.5f) / n + 0.71f;
      noise.fbm_n(u.data(), v.data(), n, 2, coarse[y]);
    }
    if (n == W && n == H) mod = coarse;
    else cv::resize(coarse, mod, cv::Size(W, H), 0, 0, cv::INTER_LINEAR);
  }
  cv::Mat1f K(H, W);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const float r = std::clamp(resistance(y, x) * (1.f + amp * mod(y, x)), 0.f, 1.f);
      K(y, x) = static_cast<float>(p.k_fluvial) * (1.f - r * (1.f - hard));
    }
  return K;
}

namespace {

// The least runoff share a cell's K is scaled by (a zero runoff would stop
// the rock eroding at all; rain.hpp's floor keeps it above this anyway).
constexpr float kMinRainShare = 1e-3f;

// Creep between channels at each finer level (creep_between_channels): σ in
// cells of that level, and the drainage area where channels begin (1 ha:
// hillslopes ~100 m long, Montgomery & Dietrich 1988). Measured on a painted
// young island at 2049² (docs/EROSION.md "Creep between channels"): the land's relief below
// 2 cells, RMS(h − G₂ h), 0.86 → 0.73 m (lowland 0.57 → 0.46 m).
constexpr double kCreepPx = 1.5;
constexpr float kChannelAreaM2 = 1e4f;

void check_erosion_inputs(const cv::Mat1f& h, const cv::Mat1f& K, double metres_per_px) {
  if (h.empty() || h.size() != K.size()) throw Error("erode: height and erodibility must be non-empty and of the same size");
  if (!(metres_per_px > 0)) throw Error("erode: metres_per_px must be > 0");
}

// The box of the active cells; empty when there is none.
cv::Rect active_box(const cv::Mat1b& role) {
  int x0 = role.cols, y0 = role.rows, x1 = -1, y1 = -1;
  for (int y = 0; y < role.rows; ++y)
    for (int x = 0; x < role.cols; ++x)
      if (role(y, x) == kActive) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  if (x1 < 0) return {};
  return cv::Rect(cv::Point(x0, y0), cv::Point(x1 + 1, y1 + 1));
}

// The surface the law sees: the sea is the base level (0 m), whatever its
// depth, so rivers cut down to the sea, not to the abyss.
cv::Mat1f base_level_surface(const cv::Mat1f& h, const cv::Mat1b& role) {
  cv::Mat1f z = h.clone();
  for (int y = 0; y < z.rows; ++y)
    for (int x = 0; x < z.cols; ++x)
      if (role(y, x) != kActive) z(y, x) = std::max(z(y, x), 0.f);
  return z;
}

// K where the wind brings the rain: × rain_rel^b (ErosionParams::
// rain_erodibility_exponent). Kauaʻi's bedrock rivers incise faster where
// it is wetter at a given stream power, the climate's hold on erodibility
// beside the discharge's (Ferrier, Huppert & Perron 2013, Nature 496:206).
cv::Mat1f wet_erodibility(const cv::Mat1f& K, const float* rain, double exponent) {
  if (!rain || !(exponent > 0)) return K;
  cv::Mat1f out(K.size());
  const float b = float(exponent);
  for (int y = 0; y < K.rows; ++y)
    for (int x = 0; x < K.cols; ++x) {
      const float r = rain[size_t(y) * size_t(K.cols) + size_t(x)];
      out(y, x) = K(y, x) * std::pow(std::max(r, kMinRainShare), b);
    }
  return out;
}

// The stack router's draw for step s on a W×H grid (0: steepest descent).
uint64_t receiver_salt(const ErosionParams& p, int W, int H, int s) {
  return p.refine_random_receivers ? mix64(uint64_t(W) * 0x10001ull + uint64_t(H) + uint64_t(s)) | 1 : 0;
}

}  // namespace

void erode_level(cv::Mat1f& h, const cv::Mat1f& K, double dx, int steps, double duration_yr, const ErosionParams& p,
                 Routing routing, double creep_px, const cv::Mat1f& rain_rel) {
  check_erosion_inputs(h, K, dx);
  if (steps <= 0 || !(duration_yr > 0)) return;
  // Islands cover a minority of the canvas: work on the land's box.
  const cv::Rect box = land_box(h);
  if (box.empty()) return;
  if (box.width < h.cols || box.height < h.rows) {
    cv::Mat1f sub = h(box).clone();
    erode_level(sub, K(box).clone(), dx, steps, duration_yr, p, routing, creep_px,
                rain_rel.empty() ? cv::Mat1f() : cv::Mat1f(rain_rel(box).clone()));
    sub.copyTo(h(box));
    return;
  }
  if (!h.isContinuous()) h = h.clone();
  const cv::Mat1b role = sea_and_edge_roles(h);
  const cv::Rect land = active_box(role);
  if (land.empty()) return;
  cv::Mat1f z = base_level_surface(h, role);
  const double dt = duration_yr / steps;
  const float cell_area_m2 = static_cast<float>(dx * dx);
  const double sigma_px = hillslope_sigma_px(p.diffusivity, dt, dx);
  // The land's box and the margin a Gaussian of `sigma` reaches beyond it.
  const auto blur_roi = [&](double sigma) {
    const int m = hillslope_margin_px(sigma);
    return cv::Rect(land.x - m, land.y - m, land.width + 2 * m, land.height + 2 * m) & cv::Rect(0, 0, h.cols, h.rows);
  };
  const cv::Rect roi = blur_roi(sigma_px);
  if (!rain_rel.empty() && (rain_rel.size() != h.size() || !rain_rel.isContinuous()))
    throw Error("erode: the rain must be a continuous field of the heights' size");
  const float* rain = rain_rel.empty() ? nullptr : rain_rel.ptr<float>();
  const cv::Mat1f K_wet = wet_erodibility(K, rain, p.rain_erodibility_exponent);
  FlowGraph graph;
  std::vector<float> area_m2;
  for (int s = 0; s < steps; ++s) {
    check_interrupt();  // a step at 8192² takes seconds: Python's Ctrl-C is read here
    if (routing == Routing::kStack) {
      route_stack(z, role, dx, receiver_salt(p, h.cols, h.rows, s), graph);
      accumulate_single(graph, role, cell_area_m2, area_m2, rain);
    } else {
      route_flood(z, role, dx, graph);
      accumulate_multiple(graph, role, cell_area_m2, dx, static_cast<float>(p.flow_exponent), area_m2, rain);
    }
    check_interrupt();
    erode_stream_power(z, K_wet, graph, area_m2, dt, p.m_area, p.channel_head_m2);
    diffuse_hillslope(z, role, roi, sigma_px);
  }
  if (creep_px > 0) creep_between_channels(z, role, blur_roi(creep_px), area_m2, kChannelAreaM2, creep_px);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x)
      if (role(y, x) == kActive) h(y, x) = z(y, x);
}

cv::Mat1f upsampled_within_cells(const cv::Mat1f& m, int side) {
  cv::Mat1f up = resampled(m, side, cv::INTER_CUBIC);
  if (side <= m.cols) return up;
  // The bounds: the highest and lowest of each cell's 3×3 neighbourhood,
  // upsampled bilinearly (continuous, so the clamp adds no edge of its own).
  cv::Mat1f most, least;
  cv::dilate(m, most, cv::Mat1b::ones(3, 3), cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  cv::erode(m, least, cv::Mat1b::ones(3, 3), cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  most = resampled(most, side, cv::INTER_LINEAR);
  least = resampled(least, side, cv::INTER_LINEAR);
  cv::min(cv::max(up, least), most, up);
  return up;
}

std::vector<int> refinement_levels(int from, int to) {
  // Doubling while a doubling leaves at least ×1.25 to go: no level adds a
  // sliver (1024 → 1025) that only costs time.
  std::vector<int> v = {std::min(from, to)};
  while (v.back() * 5 < to * 2) v.push_back(v.back() * 2);
  if (v.back() != to) v.push_back(to);
  return v;
}

cv::Mat1f resampled(const cv::Mat1f& m, int size, int interpolation) {
  if (m.cols == size && m.rows == size) return m.clone();
  cv::Mat1f out;
  cv::resize(m, out, cv::Size(size, size), 0, 0, interpolation);
  return out;
}

cv::Mat1f upsampled_level(const cv::Mat1f& m, int side, double sigma_cells) {
  cv::Mat1f up = resampled(m, side, cv::INTER_CUBIC);
  if (side <= m.cols || sigma_cells <= 0) return up;
  const double sigma_px = sigma_cells * side / m.cols;
  cv::GaussianBlur(up, up, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  return up;
}

cv::Mat1f fractal_detail(int L, const cv::Mat1f& up, double world_size_m, uint64_t seed, cv::Point origin) {
  const NoiseTile& tile = NoiseTile::get(3);
  Rng rng(seed, static_cast<uint64_t>(L), "refine-detail");
  const float u0 = float(rng.uniform(0, NoiseTile::kSize)), v0 = float(rng.uniform(0, NoiseTile::kSize));
  cv::Mat1f d(up.size(), 0.f);
  const float amp = static_cast<float>(0.4 * world_size_m / L);
  const float texels_per_cell = float(NoiseTile::kBaseCell) / 4.f;  // a base feature every 4 cells
  for (int y = 0; y < up.rows; ++y)
    for (int x = 0; x < up.cols; ++x)
      if (up(y, x) > 0)
        d(y, x) = amp * std::min(1.f, up(y, x) / 5.f) *
                  tile.sample(float(origin.x + x) * texels_per_cell + u0, float(origin.y + y) * texels_per_cell + v0);
  return d;
}

cv::Mat1f refine_heights(const cv::Mat1f& coarse_m, const cv::Mat1f& land_m, const cv::Mat1f& resistance,
                         double world_size_m, uint64_t seed, const ErosionParams& p,
                         const std::function<cv::Mat1f(int, const cv::Mat1f&)>& detail, const cv::Mat1f& rain_rel) {
  const int N = land_m.cols;
  const auto levels = refinement_levels(coarse_m.cols, N);
  cv::Mat1f cur = coarse_m.clone();
  double duration = p.refine_duration_yr;
  ErosionParams fine = p;
  fine.diffusivity *= p.refine_diffusivity_scale;
  const float detail_scale = float(p.refine_detail_scale);
  for (size_t li = 1; li < levels.size(); ++li) {
    const int L = levels[li];
    cv::Mat1f up = upsampled_level(cur, L, p.refine_upsample_sigma);
    const cv::Mat1f land_L = resampled(land_m, L, cv::INTER_AREA);
    // Each of a level's passes takes up to a second at 8192²: a host's stop
    // (Python's Ctrl-C, reefgen/interrupt.hpp) is read between them.
    check_interrupt();
    const cv::Mat1f d = detail ? detail(L, up) : cv::Mat1f();
    check_interrupt();
    cv::Mat1f next = land_L.clone();
    for (int y = 0; y < L; ++y)
      for (int x = 0; x < L; ++x)
        if (land_L(y, x) > 0) next(y, x) = std::max(up(y, x) + (d.empty() ? 0.f : detail_scale * d(y, x)), 0.f);
    const cv::Mat1f K = erodibility_map(resampled(resistance, L, cv::INTER_AREA), seed, p);
    check_interrupt();
    erode_level(next, K, world_size_m / L, p.refine_steps, duration, fine, Routing::kStack, kCreepPx,
                rain_rel.empty() ? cv::Mat1f() : resampled(rain_rel, L, cv::INTER_AREA));
    duration *= 0.5;
    cur = std::move(next);
  }
  cv::Mat1f out = land_m.clone();
  check_interrupt();
  if (cur.cols != N) cur = resampled(cur, N, cv::INTER_CUBIC);
  for (int y = 0; y < N; ++y)
    for (int x = 0; x < N; ++x)
      if (land_m(y, x) > 0) out(y, x) = std::max(cur(y, x), std::min(land_m(y, x), kLandFloorM));
  return out;
}

namespace {

// Cells outside `known` take the mean of their known 8 neighbours, ring by
// ring, `rings` times: the share the trunk kept, carried a few cells over
// the sea so that the bicubic upsampling of the coast's cells does not lean
// on the sea's 1 (a lip of unlowered land along the coast).
void extend_over_unknown(cv::Mat1f& v, cv::Mat1b known, int rings) {
  const int H = v.rows, W = v.cols;
  for (int r = 0; r < rings; ++r) {
    cv::Mat1b next = known.clone();
    cv::Mat1f out = v.clone();
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        if (known(y, x)) continue;
        float sum = 0;
        int n = 0;
        for (int yy = std::max(y - 1, 0); yy <= std::min(y + 1, H - 1); ++yy)
          for (int xx = std::max(x - 1, 0); xx <= std::min(x + 1, W - 1); ++xx)
            if (known(yy, xx)) sum += v(yy, xx), ++n;
        if (n > 0) out(y, x) = sum / float(n), next(y, x) = 1;
      }
    v = std::move(out);
    known = std::move(next);
  }
}

// The trunk lowers a cell to no less than this share of its rendered height:
// it places the basins and the base grid cuts them. Lowered to the sea, a
// trunk cell of 94 m left the base grid a flat floor at 0.1 m reaching
// 600 m inland on the young volcano (25 % of its land below 3 m, against
// 11 % without the trunk; 12 % with this floor).
constexpr float kTrunkMinKeptShare = 0.35f;

// Rings of sea cells the trunk's kept share is carried over: the base grid's
// bicubic reaches 2 trunk cells, and one more covers the blur.
constexpr int kTrunkSeaRings = 3;

}  // namespace

cv::Mat1f trunk_kept_share(const cv::Mat1f& render_m, const cv::Mat1f& rho, double world_size_m, uint64_t seed,
                           const ErosionParams& p, int T, double duration_yr, const cv::Mat1f& rain_rel) {
  if (render_m.empty() || render_m.size() != rho.size() || T < 2)
    throw Error("erode: the trunk grid needs heights and resistance of one size and at least 2 cells");
  const cv::Mat1f before = resampled(render_m, T, cv::INTER_AREA);
  cv::Mat1f after = before.clone();
  erode_level(after, erodibility_map(resampled(rho, T, cv::INTER_AREA), seed, p), world_size_m / T, p.steps,
              duration_yr, p, Routing::kFlood, 0, rain_rel.empty() ? cv::Mat1f() : resampled(rain_rel, T, cv::INTER_AREA));
  cv::Mat1f kept(T, T, 1.f);
  cv::Mat1b land(T, T);
  for (int y = 0; y < T; ++y)
    for (int x = 0; x < T; ++x) {
      land(y, x) = before(y, x) > 0;
      if (land(y, x)) kept(y, x) = std::clamp(after(y, x) / before(y, x), kTrunkMinKeptShare, 1.f);
    }
  extend_over_unknown(kept, land, kTrunkSeaRings);
  return kept;
}

cv::Mat1f erode_island(const cv::Mat1f& h_N, const cv::Mat1f& rho_N, double world_size_m, uint64_t seed,
                       const ErosionParams& asked, const cv::Mat1f& rain_N) {
  if (!asked.enabled) return h_N.clone();
  if (h_N.empty() || h_N.size() != rho_N.size() || h_N.rows != h_N.cols)
    throw Error("erode: height and resistance must be square and of the same size");
  const ErosionParams p = scaled_to_canvas(asked, world_size_m, h_N.cols);
  const int N = h_N.cols, B = std::min(N, p.base_px);
  cv::Mat1f base = resampled(h_N, B, cv::INTER_AREA);
  if (!rain_N.empty() && rain_N.size() != h_N.size()) throw Error("erode: the rain must be of the heights' size");
  double base_duration_yr = p.duration_yr;
  if (p.trunk_px > 0 && p.trunk_px < B && p.trunk_share > 0) {
    const double trunk_yr = p.duration_yr * p.trunk_share;
    const cv::Mat1f kept = upsampled_level(trunk_kept_share(h_N, rho_N, world_size_m, seed, p, p.trunk_px, trunk_yr, rain_N),
                                           B, p.refine_upsample_sigma);
    for (int y = 0; y < B; ++y)
      for (int x = 0; x < B; ++x)
        if (base(y, x) > 0) base(y, x) = std::max(base(y, x) * kept(y, x), kLandFloorM);
    base_duration_yr -= trunk_yr;
  }
  erode_level(base, erodibility_map(resampled(rho_N, B, cv::INTER_AREA), seed, p), world_size_m / B, p.steps,
              base_duration_yr, p, Routing::kFlood, 0,
              rain_N.empty() ? cv::Mat1f() : resampled(rain_N, B, cv::INTER_AREA));
  // Detail of level L = what the render holds at L beyond the level before it.
  cv::Mat1f prev_down = resampled(h_N, B, cv::INTER_AREA);
  auto detail = [&](int L, const cv::Mat1f& up) {
    cv::Mat1f down = resampled(h_N, L, cv::INTER_AREA);
    // Upsampled as the eroded level is, so their difference (the erosion's
    // own change) is all that is upsampled and the render's detail stays.
    const cv::Mat1f render_up = upsampled_level(prev_down, L, p.refine_upsample_sigma);
    cv::Mat1f d = down - render_up;
    // The render's detail survives as far as the erosion kept the surface:
    // where a basin was lowered to a third, a third of the render's knees
    // (the beach's break of slope) stays, not a ridge standing in the basin.
    for (int y = 0; y < L; ++y)
      for (int x = 0; x < L; ++x)
        if (render_up(y, x) > 0) d(y, x) *= std::clamp(up(y, x) / render_up(y, x), 0.f, 1.f);
    prev_down = std::move(down);
    return cv::Mat1f(d + fractal_detail(L, up, world_size_m, seed));
  };
  cv::Mat1f out = refine_heights(base, h_N, rho_N, world_size_m, seed, p, detail, rain_N);
  drain_pits(out, kPitDepthM, float(p.pit_breach_m), world_size_m / N);
  grade_land(out, world_size_m / N);
  return out;
}

cv::Mat1f resistance_of_labels(const cv::Mat1b& label) {
  // Means of the default ρ(x̃) over each region's x̃ range (docs/EROSION.md).
  static constexpr float kRho[5] = {0.55f, 0.10f, 0.06f, 0.60f, 0.05f};
  cv::Mat1f rho(label.size());
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < label.cols; ++x) rho(y, x) = kRho[std::min<int>(label(y, x), 4)];
  // Regions blend over ~1 % of the canvas instead of switching at a pixel.
  // At 8192² that is an 82-px σ: past 1600 px computed on a coarse grid (wide_blur.hpp).
  return wide_gaussian_blur(rho, std::max(1.0, 0.01 * label.cols));
}

}  // namespace reefgen::terrain
