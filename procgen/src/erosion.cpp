#include "reefgen/procgen/erosion.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <type_traits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "reefgen/io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/procgen/noise.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/terrain.hpp"

namespace reefgen::procgen {

using nlohmann::json;

void to_json(json& j, const ErosionParams& p) { j = params_json(p); }

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
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        coarse(y, x) = noise.fbm(4.f * (x + 0.5f) / n + 0.37f, 4.f * (y + 0.5f) / n + 0.71f, 2);
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

// Braun & Willett (2013) routing in O(n): steepest-descent receivers on z,
// then the donor tree walked from every outlet (and every local minimum,
// which is its own receiver), so each cell comes after its receiver. Used on
// the refinement levels, whose surface the base level has already drained.
// salt = 0: each cell drains to its steepest lower neighbour (D8). salt ≠ 0:
// to a lower neighbour drawn with probability ∝ slope² from a hash of (cell,
// salt), the same whatever the threads: on a smooth slope D8 draws straight
// gullies along the 8 grid directions, random receivers let them wander.
void stack_route(uint64_t salt, const float* z, const uint8_t* rl, int W, int H, float inv_dx,
                 float inv_diag, std::vector<int>& recv, std::vector<float>& inv_l, std::vector<int>& order) {
  static constexpr int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1}, kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  const float inv_len[8] = {inv_dx, inv_dx, inv_dx, inv_dx, inv_diag, inv_diag, inv_diag, inv_diag};
  const int n = W * H;
  std::vector<int> ndon(n + 1, 0);
  for (int i = 0; i < n; ++i) {
    recv[i] = i;
    if (rl[i] != kActive) continue;
    const int x = i % W, y = i / W;
    float best_s = 0.f, w[8], sum = 0.f;
    for (int k = 0; k < 8; ++k) {
      w[k] = 0.f;
      const int nx = x + kDx[k], ny = y + kDy[k];
      if (nx < 0 || ny < 0 || nx >= W || ny >= H) continue;
      const int j = ny * W + nx;
      if (rl[j] == kIgnore) continue;
      const float sl = (z[i] - z[j]) * inv_len[k];
      if (sl > 0.f) sum += (w[k] = sl * sl);
      if (sl > best_s) best_s = sl, recv[i] = j, inv_l[i] = inv_len[k];
    }
    if (salt != 0 && sum > 0.f) {
      const float u = float(mix64(salt ^ mix64(uint64_t(i))) >> 40) * (1.f / 16777216.f) * sum;
      float c = 0.f;
      for (int k = 0; k < 8; ++k) {
        if (w[k] <= 0.f) continue;
        c += w[k];
        recv[i] = (y + kDy[k]) * W + x + kDx[k];
        inv_l[i] = inv_len[k];
        if (u < c) break;
      }
    }
    if (recv[i] != i) ++ndon[recv[i] + 1];
  }
  for (int i = 0; i < n; ++i) ndon[i + 1] += ndon[i];
  std::vector<int> donors(ndon[n]), fill(ndon.begin(), ndon.end() - 1);
  for (int i = 0; i < n; ++i)
    if (recv[i] != i) donors[fill[recv[i]]++] = i;
  order.clear();
  size_t head = 0;
  for (int i = 0; i < n; ++i) {
    if (recv[i] != i || ndon[i + 1] == ndon[i]) continue;  // not a base level, or drains nothing
    // Breadth-first from this base level: receivers before donors.
    const size_t start = order.size();
    for (int k = ndon[i]; k < ndon[i + 1]; ++k) order.push_back(donors[k]);
    for (head = start; head < order.size(); ++head) {
      const int c = order[head];
      for (int k = ndon[c]; k < ndon[c + 1]; ++k) order.push_back(donors[k]);
    }
  }
}

}  // namespace

void erode_level(cv::Mat1f& h, const cv::Mat1f& K, double dx, int steps, double duration_yr, const ErosionParams& p,
                 Routing routing) {
  if (h.empty() || h.size() != K.size()) throw Error("erode: height and erodibility must be non-empty and of the same size");
  if (!(dx > 0)) throw Error("erode: metres_per_px must be > 0");
  if (steps <= 0 || !(duration_yr > 0)) return;
  // Work on the land's bounding box plus one cell (all outlets, or the canvas
  // edge): islands cover a minority of the canvas.
  {
    int x0 = h.cols, y0 = h.rows, x1 = -1, y1 = -1;
    for (int y = 0; y < h.rows; ++y) {
      const float* r = h.ptr<float>(y);
      for (int x = 0; x < h.cols; ++x)
        if (r[x] > 0) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
    if (x1 < 0) return;  // no land
    const cv::Rect box(cv::Point(std::max(0, x0 - 1), std::max(0, y0 - 1)),
                       cv::Point(std::min(h.cols, x1 + 2), std::min(h.rows, y1 + 2)));
    if (box.width < h.cols || box.height < h.rows) {
      cv::Mat1f sub = h(box).clone();
      erode_level(sub, K(box).clone(), dx, steps, duration_yr, p, routing);
      sub.copyTo(h(box));
      return;
    }
  }
  if (!h.isContinuous()) h = h.clone();
  const int H = h.rows, W = h.cols;
  const cv::Mat1b role = sea_and_edge_roles(h);
  const uint8_t* rl = role.ptr<uint8_t>();
  // z: the surface the law sees. The sea is the base level (0 m), whatever
  // its depth: rivers cut down to the sea, not to the abyss.
  cv::Mat1f z = h.clone();
  float* zp = z.ptr<float>();
  int x0 = W, y0 = H, x1 = -1, y1 = -1;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int i = y * W + x;
      if (rl[i] == kActive) {
        x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
      } else {
        zp[i] = std::max(zp[i], 0.f);
      }
    }
  if (x1 < 0) return;  // no land
  const double dt = duration_yr / steps;
  const float cell_area = static_cast<float>(dx * dx), m = static_cast<float>(p.m_area);
  const float inv_dx = static_cast<float>(1.0 / dx), inv_diag = static_cast<float>(1.0 / (dx * std::sqrt(2.0)));
  const float* kp = K.ptr<float>();
  std::vector<float> area(static_cast<size_t>(H) * W, 0.f);
  // Diffusion over dt on an infinite plane is a Gaussian of σ = sqrt(2 D dt):
  // exact for the linear term, no stability limit (explicit schemes need
  // dt ≤ dx²/4D, i.e. thousands of steps at 4097²).
  const double sigma_px = std::sqrt(2.0 * p.diffusivity * dt) / dx;
  const int margin = static_cast<int>(std::ceil(3 * sigma_px)) + 1;
  const cv::Rect roi = cv::Rect(cv::Point(std::max(0, x0 - margin), std::max(0, y0 - margin)),
                                cv::Point(std::min(W, x1 + margin + 1), std::min(H, y1 + margin + 1)));
  cv::Mat1f blurred;
  static constexpr int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1}, kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  const float inv_len[8] = {inv_dx, inv_dx, inv_dx, inv_dx, inv_diag, inv_diag, inv_diag, inv_diag};
  int offset[8];
  for (int d = 0; d < 8; ++d) offset[d] = kDy[d] * W + kDx[d];
  const float conc = static_cast<float>(p.flow_exponent);
  std::vector<int> recv(static_cast<size_t>(H) * W);
  std::vector<float> inv_l(static_cast<size_t>(H) * W);
  std::vector<int> stack_order;
  for (int s = 0; s < steps; ++s) {
    if (routing == Routing::kStack) {
      const uint64_t salt = p.refine_random_receivers ? mix64(uint64_t(W) * 0x10001ull + uint64_t(H) + uint64_t(s)) | 1 : 0;
      stack_route(salt, zp, rl, W, H, inv_dx, inv_diag, recv, inv_l, stack_order);
      for (const int i : stack_order) area[i] = cell_area;
      for (size_t k = stack_order.size(); k-- > 0;) {
        const int i = stack_order[k];
        if (rl[recv[i]] == kActive) area[recv[i]] += area[i];
      }
      for (const int i : stack_order) {
        const float F = kp[i] * static_cast<float>(dt) * std::exp(m * std::log(area[i])) * inv_l[i];
        zp[i] = (zp[i] + F * zp[recv[i]]) / (1.f + F);
      }
    } else {
    const FloodRoute fr = flood_route(z, role);
    const auto& order = fr.order;
    const float* fz = fr.filled.ptr<float>();
    for (const int i : order) area[i] = cell_area;
    // One pass from the highest cell down, each cell's eight slopes on the
    // filled surface computed once for both of its uses. Active cells are
    // never on the canvas edge (sea_and_edge_roles makes it an outlet), so
    // every neighbour is at a flat-index offset.
    // Receiver = steepest descent on the filled surface (lower neighbours were
    // taken out of the flood's queues first); in a filled depression, where
    // no neighbour is lower, the flood's own path to the spill point.
    // Drainage area with multiple flow directions (Quinn et al. 1991: shares
    // ∝ slope^p over the lower neighbours): a single steepest direction draws
    // straight parallel gullies along the 8 grid directions on smooth slopes.
    // The exponent's test is taken out of the cell loop (Quinn's p = 1 is the
    // default: the share is the slope itself).
    auto route_and_accumulate = [&](auto unit_exponent) {
      for (size_t k = order.size(); k-- > 0;) {
        const int i = order[k];
        float sl[8];
        for (int d = 0; d < 8; ++d) sl[d] = (fz[i] - fz[i + offset[d]]) * inv_len[d];
        int best = fr.receiver[i];
        const int step = best - i;
        float best_s = 0.f, best_l = (step == 1 || step == -1 || step == W || step == -W) ? inv_dx : inv_diag;
        for (int d = 0; d < 8; ++d)
          if (sl[d] > best_s) best_s = sl[d], best = i + offset[d], best_l = inv_len[d];
        recv[i] = best;
        inv_l[i] = best_l;
        // Non-lower neighbours get a zero share; adding +0 leaves the sum's bits as they are.
        float w[8], sum = 0.f;
        for (int d = 0; d < 8; ++d) {
          w[d] = sl[d] > 0.f ? (decltype(unit_exponent)::value ? sl[d] : std::pow(sl[d], conc)) : 0.f;
          sum += w[d];
        }
        if (sum <= 0.f) {  // filled depression: all to the flood's path
          if (rl[best] == kActive) area[best] += area[i];
          continue;
        }
        const float a = area[i] / sum;
        for (int d = 0; d < 8; ++d)
          if (w[d] > 0.f) {
            const int j = i + offset[d];
            if (rl[j] == kActive) area[j] += a * w[d];
          }
      }
    };
    if (conc == 1.f) route_and_accumulate(std::true_type{});
    else route_and_accumulate(std::false_type{});
    // Implicit stream power (n = 1), receivers first: z_i ← (z_i + F z_r)/(1 + F),
    // F = K dt A^m / L. Where the receiver is higher (a closed depression,
    // routed to its spill point) the same update raises the cell towards it:
    // sediment fills the basin instead of water standing in it.
    for (const int i : order) {
      const float F = kp[i] * static_cast<float>(dt) * std::exp(m * std::log(area[i])) * inv_l[i];
      zp[i] = (zp[i] + F * zp[recv[i]]) / (1.f + F);
    }
    }
    if (sigma_px > 0.15) {
      cv::GaussianBlur(z(roi), blurred, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
      for (int y = roi.y; y < roi.y + roi.height; ++y) {
        const float* b = blurred.ptr<float>(y - roi.y);
        for (int x = roi.x; x < roi.x + roi.width; ++x) {
          const int i = y * W + x;
          if (rl[i] == kActive) zp[i] = std::max(b[x - roi.x], 0.f);
        }
      }
    }
  }
  float* hp = h.ptr<float>();
  for (int i = 0; i < H * W; ++i)
    if (rl[i] == kActive) hp[i] = zp[i];
}

std::vector<int> refinement_levels(int from, int to) {
  // Doubling while a doubling leaves at least ×1.25 to go: no level adds a
  // sliver (1024 → 1025) that only costs time.
  std::vector<int> v = {std::min(from, to)};
  while (v.back() * 5 < to * 2) v.push_back(v.back() * 2);
  if (v.back() != to) v.push_back(to);
  return v;
}

namespace {
cv::Mat1f resized(const cv::Mat1f& m, int size, int interpolation) {
  if (m.cols == size && m.rows == size) return m.clone();
  cv::Mat1f out;
  cv::resize(m, out, cv::Size(size, size), 0, 0, interpolation);
  return out;
}

// Detail a refinement level adds on land: an fBm tile at 4 cells per
// feature (3 octaves), ± 0.4 cell sizes in metres (relief that grows with the scale, as
// in fractal terrain), faded in over the first 5 m above the sea so that
// coastlines stay where they were. The erosion that follows turns it into
// the heads of small valleys instead of leaving it as noise.
cv::Mat1f fractal_detail(int L, const cv::Mat1f& up, double world_size_m, uint64_t seed) {
  const NoiseTile& tile = NoiseTile::get(3);
  Rng rng(seed, static_cast<uint64_t>(L), "refine-detail");
  const float u0 = float(rng.uniform(0, NoiseTile::kSize)), v0 = float(rng.uniform(0, NoiseTile::kSize));
  cv::Mat1f d(L, L, 0.f);
  const float amp = static_cast<float>(0.4 * world_size_m / L);
  const float texels_per_cell = float(NoiseTile::kBaseCell) / 4.f;  // a base feature every 4 cells
  for (int y = 0; y < L; ++y)
    for (int x = 0; x < L; ++x)
      if (up(y, x) > 0)
        d(y, x) = amp * std::min(1.f, up(y, x) / 5.f) * tile.sample(x * texels_per_cell + u0, y * texels_per_cell + v0);
  return d;
}
}  // namespace

cv::Mat1f refine_heights(const cv::Mat1f& coarse_m, const cv::Mat1f& land_m, const cv::Mat1f& resistance,
                         double world_size_m, uint64_t seed, const ErosionParams& p,
                         const std::function<cv::Mat1f(int, const cv::Mat1f&)>& detail) {
  const int N = land_m.cols;
  const auto levels = refinement_levels(coarse_m.cols, N);
  cv::Mat1f cur = coarse_m.clone();
  double duration = p.refine_duration_yr;
  ErosionParams fine = p;
  fine.diffusivity *= p.refine_diffusivity_scale;
  const float detail_scale = float(p.refine_detail_scale);
  for (size_t li = 1; li < levels.size(); ++li) {
    const int L = levels[li];
    cv::Mat1f up = resized(cur, L, cv::INTER_CUBIC);
    const cv::Mat1f land_L = resized(land_m, L, cv::INTER_AREA);
    const cv::Mat1f d = detail ? detail(L, up) : cv::Mat1f();
    cv::Mat1f next = land_L.clone();
    for (int y = 0; y < L; ++y)
      for (int x = 0; x < L; ++x)
        if (land_L(y, x) > 0) next(y, x) = std::max(up(y, x) + (d.empty() ? 0.f : detail_scale * d(y, x)), 0.f);
    erode_level(next, erodibility_map(resized(resistance, L, cv::INTER_AREA), seed, p), world_size_m / L,
                p.refine_steps, duration, fine, Routing::kStack);
    duration *= 0.5;
    cur = std::move(next);
  }
  cv::Mat1f out = land_m.clone();
  if (cur.cols != N) cur = resized(cur, N, cv::INTER_CUBIC);
  for (int y = 0; y < N; ++y)
    for (int x = 0; x < N; ++x)
      if (land_m(y, x) > 0) out(y, x) = std::max(cur(y, x), std::min(land_m(y, x), 0.1f));
  return out;
}

cv::Mat1f erode_island(const cv::Mat1f& h_N, const cv::Mat1f& rho_N, double world_size_m, uint64_t seed,
                       const ErosionParams& p) {
  if (!p.enabled) return h_N.clone();
  if (h_N.empty() || h_N.size() != rho_N.size() || h_N.rows != h_N.cols)
    throw Error("erode: height and resistance must be square and of the same size");
  const int N = h_N.cols, B = std::min(N, p.base_px);
  cv::Mat1f base = resized(h_N, B, cv::INTER_AREA);
  erode_level(base, erodibility_map(resized(rho_N, B, cv::INTER_AREA), seed, p), world_size_m / B, p.steps,
              p.duration_yr, p);
  // Detail of level L = what the render holds at L beyond the level before it.
  cv::Mat1f prev_down = resized(h_N, B, cv::INTER_AREA);
  auto detail = [&](int L, const cv::Mat1f& up) {
    cv::Mat1f down = resized(h_N, L, cv::INTER_AREA);
    cv::Mat1f d = down - resized(prev_down, L, cv::INTER_CUBIC);
    prev_down = std::move(down);
    return cv::Mat1f(d + fractal_detail(L, up, world_size_m, seed));
  };
  cv::Mat1f out = refine_heights(base, h_N, rho_N, world_size_m, seed, p, detail);
  drain_pits(out, 0.5f, float(p.pit_breach_m));
  return out;
}

int64_t drain_pits(cv::Mat1f& h, float max_depth_m, float breach_m) {
  if (!h.isContinuous()) h = h.clone();
  const FloodRoute fr = flood_route(h, sea_and_edge_roles(h));
  const int n = h.rows * h.cols;
  float* z = h.ptr<float>();
  const float* spill = fr.filled.ptr<float>();
  // Filled: a closed depression deeper than breach_m is raised to breach_m
  // below its spill level (a lake floor); what is left, at most breach_m, is
  // breached below.
  const float lake_floor_m = std::max(max_depth_m, breach_m);
  std::vector<uint8_t> moved(size_t(n), 0);
  std::vector<int> pits;
  for (int i = 0; i < n; ++i) {
    if (!(z[i] > 0 && z[i] < spill[i] - max_depth_m)) continue;
    if (z[i] < spill[i] - lake_floor_m) {
      z[i] = spill[i] - lake_floor_m;
      moved[size_t(i)] = 1;
    }
    pits.push_back(i);
  }
  if (breach_m > max_depth_m) {
    // Breached (Lindsay 2016): a shallow depression keeps its own relief and
    // its outflow path is cut down instead. Filling it would leave a dead-flat
    // floor; behind a coast's thin rim these floors were a ring of flats
    // around every island (docs/EROSION.md). From the lowest depression cell
    // up, the flood's route to the outlet (through the spill point) is made
    // non-ascending by lowering the cells above the level carried along it.
    // A walk stops on a cell an earlier, lower walk already made drain: from
    // there on the path is non-ascending below that cell.
    std::sort(pits.begin(), pits.end(), [&](int a, int b) { return z[a] < z[b] || (z[a] == z[b] && a < b); });
    std::vector<uint8_t> drains(size_t(n), 0);
    for (const int i : pits) {
      float level = z[i];
      for (int j = fr.receiver[size_t(i)]; j != i;) {
        if (drains[size_t(j)] && z[j] <= level) break;
        if (z[j] > level) {
          z[j] = level;
          moved[size_t(j)] = 1;
        }
        level = z[j];
        drains[size_t(j)] = 1;
        const int next = fr.receiver[size_t(j)];
        if (next == j) break;  // an outlet: the sea or the canvas edge
        j = next;
      }
      drains[size_t(i)] = 1;
    }
  }
  int64_t changed = 0;
  for (const uint8_t m : moved) changed += m;
  return changed;
}

cv::Mat1f resistance_of_labels(const cv::Mat1b& label) {
  // Means of the default ρ(x̃) over each region's x̃ range (docs/EROSION.md).
  static constexpr float kRho[5] = {0.55f, 0.10f, 0.06f, 0.60f, 0.05f};
  cv::Mat1f rho(label.size());
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < label.cols; ++x) rho(y, x) = kRho[std::min<int>(label(y, x), 4)];
  // Regions blend over ~1 % of the canvas instead of switching at a pixel.
  const double s = std::max(1.0, 0.01 * label.cols);
  cv::GaussianBlur(rho, rho, cv::Size(0, 0), s, s, cv::BORDER_REPLICATE);
  return rho;
}

namespace {
// A model answer is smoother than a rendered island (an L1-trained network
// predicts the mean of the valleys it cannot place), so a cone would shed
// water radially and erosion on it carves few valleys. Relief proportional
// to height (fBm, one feature per amplify_feature_m) gives the drainage
// somewhere to start, as the render's noise does for the generator; the
// coast (h → 0) does not move.
// A painted island comes back from the model with round contours: a cone
// whose plan curvature is divergent (+1/r) everywhere, so water spreads and
// erosion carves few valleys. Real volcanic flanks are lobed (lava flows,
// landslide scars), as the generator's irregular outlines are. Each flank
// contour is pushed up or down the slope by a noise of one feature per
// amplify_lobe_spacing_m (h'(x) = h(x − d(x)·∇h/|∇h|), |d| ≤ amplify_lobe_m),
// faded in over the lowest 20 % of each island (of its own peak) so the
// coast stays where the sketch put it; the concave bends then gather the
// water the base-grid erosion turns into valleys (docs/EROSION.md).
// Each cell's island (8-connected land; 0 = sea) and each island's highest height.
std::vector<float> island_peaks(const cv::Mat1f& h, cv::Mat1i& island) {
  const int islands = cv::connectedComponents(cv::Mat1b(h > 0), island, 8, CV_32S);
  std::vector<float> peak(size_t(islands), 0.f);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) peak[size_t(island(y, x))] = std::max(peak[size_t(island(y, x))], h(y, x));
  return peak;
}

void lobe_contours(cv::Mat1f& h, double world_size_m, uint64_t seed, const ErosionParams& p) {
  if (p.amplify_lobe_m <= 0) return;
  const int S = h.cols;
  const double cell_m = world_size_m / S;
  double hmax = 0;
  cv::minMaxLoc(h, nullptr, &hmax);
  if (hmax <= 1) return;
  cv::Mat1f sm;
  const double sig = std::max(1.0, 0.25 * p.amplify_lobe_spacing_m / cell_m);
  cv::GaussianBlur(h, sm, cv::Size(0, 0), sig, sig, cv::BORDER_REPLICATE);
  cv::Mat1f gx, gy;
  cv::Sobel(sm, gx, CV_32F, 1, 0, 3, 1.0 / 8);
  cv::Sobel(sm, gy, CV_32F, 0, 1, 3, 1.0 / 8);
  const NoiseTile& tile = NoiseTile::get(2);
  Rng rng(seed, 0, "amplify-lobes");
  const float u0 = float(rng.uniform(0, NoiseTile::kSize)), v0 = float(rng.uniform(0, NoiseTile::kSize));
  const float tpc = float(NoiseTile::kBaseCell * cell_m / p.amplify_lobe_spacing_m);
  const float amp_px = float(p.amplify_lobe_m / cell_m);
  // Each island is lobed from 20 % of its own peak: a low, older island
  // beside a young volcano has a flank of its own (with the canvas's peak it
  // would stay a smooth dome).
  cv::Mat1i island;
  const std::vector<float> peak = island_peaks(h, island);
  auto foot_m = [&](int y, int x) { return std::max(0.2f * peak[size_t(island(y, x))], 1e-3f); };
  // The noise is read where each cell's flow line (steepest descent on the
  // smoothed heights) reaches the foot of the flank (foot_m), so every cell of
  // one flow line gets the same push: the contours above it shift together
  // and the lobes run continuously up the slope as spurs and re-entrants (a
  // 2D noise bends each contour on its own, and its bends do not line up
  // into valleys). Flow lines converge uphill, so the lobes narrow towards
  // the summit, as real valley heads do.
  cv::Mat1f noise_u(S, S), noise_v(S, S);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      float px = float(x), py = float(y);
      if (p.amplify_lobe_along_flow && h(y, x) > 0) {
        const float h_foot = foot_m(y, x);
        for (int step = 0; step < 2 * S; ++step) {
          const int ix = std::clamp(int(px + 0.5f), 0, S - 1), iy = std::clamp(int(py + 0.5f), 0, S - 1);
          if (sm(iy, ix) <= h_foot) break;
          const float gxx = gx(iy, ix), gyy = gy(iy, ix), g = std::hypot(gxx, gyy);
          if (g < 1e-6f) break;
          px -= gxx / g;
          py -= gyy / g;
        }
      }
      noise_u(y, x) = px;
      noise_v(y, x) = py;
    }
  cv::Mat1f mx(S, S), my(S, S);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      const float t = std::clamp(h(y, x) / foot_m(y, x), 0.f, 1.f), w = t * t * (3 - 2 * t);
      const float g = std::hypot(gx(y, x), gy(y, x));
      // 1/|∇h|, faded in below a 2 % slope (summits, plains: no direction)
      const float k = std::min(1.f, g * float(1.0 / (0.02 * cell_m))) / std::max(g, 1e-6f);
      const float d = w * amp_px * tile.sample(noise_u(y, x) * tpc + u0, noise_v(y, x) * tpc + v0);
      mx(y, x) = float(x) - d * gx(y, x) * k;
      my(y, x) = float(y) - d * gy(y, x) * k;
    }
  cv::Mat1f out;
  cv::remap(h, out, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x)
      if (h(y, x) > 0) h(y, x) = std::max(0.1f, out(y, x));
}

void roughen_land(cv::Mat1f& h, double world_size_m, uint64_t seed, const ErosionParams& p) {
  lobe_contours(h, world_size_m, seed, p);
  if (p.amplify_roughness <= 0) return;
  const int S = h.cols;
  const NoiseTile& tile = NoiseTile::get(3);
  Rng rng(seed, 0, "amplify-rough");
  const float u0 = float(rng.uniform(0, NoiseTile::kSize)), v0 = float(rng.uniform(0, NoiseTile::kSize));
  const float texels_per_cell = float(NoiseTile::kBaseCell * world_size_m / (S * p.amplify_feature_m));
  const float a = float(p.amplify_roughness);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x)
      if (h(y, x) > 0)
        h(y, x) = std::max(0.1f, h(y, x) * (1.f + a * tile.sample(x * texels_per_cell + u0, y * texels_per_cell + v0)));
}
// The model answers a painted sketch whose beach and lagoon bands have even
// widths with concentric ridges and moats on the low plain (about 10 m high,
// a few hundred metres apart, following the painted band edges): rings no
// rendered island has, which the erosion keeps (a moat is filled flat, a
// ridge is eroded from both sides). On the land of the beach, lagoon and reef
// regions the answer is replaced by its land-only Gaussian mean (normalised
// convolution, so the sea does not pull the plain down), faded out towards
// the coast (h < 5 m) so the coastline stays where the model put it; the
// roughening and the erosion then give the plain its relief, as the render
// and the erosion do for the generator (docs/EROSION.md).
// A low island (an older, subsided one) comes back as a low dome ringed by
// the same ridges and moats, on its mountain too, where they are as high as
// the dome's own relief: islands whose own peak is below low_island_m are
// smoothed over all their land (fully below half of it, fading out up to it).
void smooth_plains(cv::Mat1f& h, const cv::Mat1b& label, double sigma_px, double low_island_m) {
  if (sigma_px <= 0) return;
  const int S = h.cols;
  cv::Mat1f land(S, S), hl(S, S), plain(S, S);
  cv::Mat1i island;
  const std::vector<float> peak = island_peaks(h, island);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      land(y, x) = h(y, x) > 0 ? 1.f : 0.f;
      hl(y, x) = h(y, x) > 0 ? h(y, x) : 0.f;
      const float low = low_island_m > 0
                            ? std::clamp(float(2.0 - 2.0 * peak[size_t(island(y, x))] / low_island_m), 0.f, 1.f)
                            : 0.f;
      plain(y, x) = (label(y, x) >= 1 && label(y, x) <= 3) ? 1.f : (h(y, x) > 0 ? low : 0.f);
    }
  cv::Mat1f bl, bh;
  cv::GaussianBlur(land, bl, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  cv::GaussianBlur(hl, bh, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  cv::GaussianBlur(plain, plain, cv::Size(0, 0), 0.5 * sigma_px, 0.5 * sigma_px, cv::BORDER_REPLICATE);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      if (h(y, x) <= 0 || bl(y, x) < 1e-3f) continue;
      const float smooth = bh(y, x) / bl(y, x);
      const float t = std::clamp(h(y, x) / 5.f, 0.f, 1.f) * plain(y, x);
      h(y, x) = std::max(0.1f, h(y, x) + t * (smooth - h(y, x)));
    }
}

// The model answers the lowland of a painted island with a speckle of small
// bumps and hollows around 0 m (docs/MODEL.md), and the hollows that dip
// below the sea become ponds of sea enclosed by land, mostly on the painted
// lagoon and reef next to the coast: 11 of the 14 painted sketches had some
// at 1025² (up to 16 ponds, 590 cells = 0.06 km², 9 m deep), where the
// generator's islands have none (62 ponds of 1–2 cells in 300 training
// targets). Sea that does not reach the canvas edge through other sea
// (8-connected) is raised to land when it is at most max_area_m2, or at any
// size when most of it was painted island or beach; a large lagoon closed by
// islets stays sea. Filled from its shore inwards, each ring with the mean
// of the cells filled before it (the floor follows the shore's heights), at
// least 0.1 m; drain_pits then gives it an outflow. Returns the cells raised.
int64_t fill_ponds(cv::Mat1f& h, const cv::Mat1b& label, double cell_m, double max_area_m2) {
  if (max_area_m2 <= 0) return 0;
  const int H = h.rows, W = h.cols;
  cv::Mat1i comp;
  cv::Mat stats, centroids;
  const int n = cv::connectedComponentsWithStats(cv::Mat1b(h <= 0.f), comp, stats, centroids, 8, CV_32S);
  std::vector<uint8_t> open_sea(size_t(n), 0);
  for (int x = 0; x < W; ++x) open_sea[size_t(comp(0, x))] = open_sea[size_t(comp(H - 1, x))] = 1;
  for (int y = 0; y < H; ++y) open_sea[size_t(comp(y, 0))] = open_sea[size_t(comp(y, W - 1))] = 1;
  int64_t raised = 0;
  std::vector<int> ring;
  std::vector<float> value;
  for (int c = 1; c < n; ++c) {
    if (open_sea[size_t(c)]) continue;
    // Not on the edge, so its box grown by one cell is inside the canvas.
    const cv::Rect box(stats.at<int>(c, cv::CC_STAT_LEFT) - 1, stats.at<int>(c, cv::CC_STAT_TOP) - 1,
                       stats.at<int>(c, cv::CC_STAT_WIDTH) + 2, stats.at<int>(c, cv::CC_STAT_HEIGHT) + 2);
    int painted_land = 0, cells = 0;
    for (int y = box.y; y < box.y + box.height; ++y)
      for (int x = box.x; x < box.x + box.width; ++x)
        if (comp(y, x) == c) ++cells, painted_land += label(y, x) <= kBeach;
    if (double(cells) * cell_m * cell_m > max_area_m2 && 2 * painted_land < cells) continue;
    cv::Mat1b known(box.size());
    for (int y = 0; y < box.height; ++y)
      for (int x = 0; x < box.width; ++x) known(y, x) = comp(box.y + y, box.x + x) != c;
    for (int left = cells; left > 0;) {
      ring.clear();
      value.clear();
      for (int y = 1; y < box.height - 1; ++y)
        for (int x = 1; x < box.width - 1; ++x) {
          if (known(y, x)) continue;
          float sum = 0.f;
          int k = 0;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx)
              if (known(y + dy, x + dx)) sum += h(box.y + y + dy, box.x + x + dx), ++k;
          if (k == 0) continue;
          ring.push_back(y * box.width + x);
          value.push_back(std::max(0.1f, sum / float(k)));
        }
      for (size_t r = 0; r < ring.size(); ++r) {
        const int y = ring[r] / box.width, x = ring[r] % box.width;
        h(box.y + y, box.x + x) = value[r];
        known(y, x) = 1;
      }
      if (ring.empty()) break;  // cannot happen (the pond is connected and bounded by land); never loop on it
      left -= int(ring.size());
      raised += int64_t(ring.size());
    }
  }
  return raised;
}
}  // namespace

cv::Mat1f amplify_heights(const cv::Mat1f& coarse_m, const cv::Mat1b& label, double world_size_m, uint64_t seed,
                          const ErosionParams& p) {
  if (coarse_m.empty() || coarse_m.rows != coarse_m.cols || label.rows != label.cols)
    throw Error("amplify: the height field and the label map must be square");
  const int S = coarse_m.cols, N = label.cols;
  cv::Mat1f coarse = coarse_m.clone();
  cv::Mat1b label_s;
  cv::resize(label, label_s, cv::Size(S, S), 0, 0, cv::INTER_NEAREST);
  const bool erode = N > S || p.amplify_erode_at_model_side;
  if (p.enabled && erode) smooth_plains(coarse, label_s, p.amplify_plain_smooth_m / (world_size_m / S), p.amplify_low_island_m);
  if (p.enabled) fill_ponds(coarse, label_s, world_size_m / S, p.amplify_pond_max_m2);
  if (p.enabled && erode) {
    roughen_land(coarse, world_size_m, seed, p);
    // Few steps (amplify_steps, not the generator's `steps`): measured, 8 steps
    // give the painted set 0.298 valleys, 3 give 0.306 (docs/EROSION.md). The
    // drainage is routed once per step; our reading is that each re-routing
    // lets the deeper valleys capture the shallow ones the lobes started.
    erode_level(coarse, erodibility_map(resistance_of_labels(label_s), seed, p), world_size_m / S, p.amplify_steps,
                p.duration_yr * p.amplify_duration_scale, p);
  }
  cv::Mat1f land = resized(coarse, N, cv::INTER_CUBIC);
  if (N <= S || !p.enabled) {
    if (N < S) cv::resize(coarse, land, cv::Size(N, N), 0, 0, cv::INTER_AREA);
    if (p.enabled) fill_ponds(land, label, world_size_m / N, p.amplify_pond_max_m2);
    drain_pits(land, 0.5f, float(p.pit_breach_m));
    return land;
  }
  auto detail = [&](int L, const cv::Mat1f& up) { return fractal_detail(L, up, world_size_m, seed); };
  cv::Mat1f out = refine_heights(coarse, land, resized(resistance_of_labels(label), N, cv::INTER_LINEAR),
                                 world_size_m, seed, p, detail);
  fill_ponds(out, label, world_size_m / N, p.amplify_pond_max_m2);
  drain_pits(out, 0.5f, float(p.pit_breach_m));
  return out;
}

}  // namespace reefgen::procgen
