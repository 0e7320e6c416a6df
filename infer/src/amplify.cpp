#include "reefgen/infer/amplify.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/infer/reef_finish.hpp"
#include "reefgen/interrupt.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/ramp.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/rows.hpp"
#include "reefgen/terrain/noise.hpp"
#include "reefgen/terrain/pits.hpp"
#include "reefgen/wide_blur.hpp"

#include "masked_blur.hpp"

namespace reefgen::infer {

using namespace reefgen::terrain;

namespace {
// Each cell's island (8-connected land; 0 = sea) and each island's highest height.
std::vector<float> island_peaks(const cv::Mat1f& h, cv::Mat1i& island) {
  const int islands = cv::connectedComponents(cv::Mat1b(h > 0), island, 8, CV_32S);
  std::vector<float> peak(size_t(islands), 0.f);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) peak[size_t(island(y, x))] = std::max(peak[size_t(island(y, x))], h(y, x));
  return peak;
}

// A painted island comes back from the model with round contours: a cone
// whose plan curvature is divergent (+1/r) everywhere, so water spreads and
// erosion carves few valleys. Real volcanic flanks are lobed (lava flows,
// landslide scars), as the generator's irregular outlines are. Each flank
// contour is pushed up or down the slope by a noise of one feature per
// lobe_spacing_m (h'(x) = h(x − d(x)·∇h/|∇h|), |d| ≤ lobe_m),
// faded in over the lowest 20 % of each island (of its own peak) so the
// coast stays where the sketch put it; the concave bends then gather the
// water the base-grid erosion turns into valleys (docs/EROSION.md).
void lobe_contours(cv::Mat1f& h, double world_size_m, uint64_t seed, const AmplifyParams& p, const cv::Mat1f& rugged) {
  if (p.lobe_m <= 0) return;
  const int S = h.cols;
  const double cell_m = world_size_m / S;
  double hmax = 0;
  cv::minMaxLoc(h, nullptr, &hmax);
  if (hmax <= 1) return;
  cv::Mat1f sm;
  const double sig = std::max(1.0, 0.25 * p.lobe_spacing_m / cell_m);
  cv::GaussianBlur(h, sm, cv::Size(0, 0), sig, sig, cv::BORDER_REPLICATE);
  cv::Mat1f gx, gy;
  cv::Sobel(sm, gx, CV_32F, 1, 0, 3, 1.0 / 8);
  cv::Sobel(sm, gy, CV_32F, 0, 1, 3, 1.0 / 8);
  const NoiseTile& tile = NoiseTile::get(2);
  Rng rng(seed, 0, "amplify-lobes");
  const float u0 = float(rng.uniform(0, NoiseTile::kSize)), v0 = float(rng.uniform(0, NoiseTile::kSize));
  const float tpc = float(NoiseTile::kBaseCell * cell_m / p.lobe_spacing_m);
  const float amp_px = float(p.lobe_m / cell_m);
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
      if (h(y, x) > 0) {
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
      const float t = std::clamp(h(y, x) / foot_m(y, x), 0.f, 1.f), w = smoothstep(t);
      const float g = std::hypot(gx(y, x), gy(y, x));
      // 1/|∇h|, faded in below a 2 % slope (summits, plains: no direction)
      const float k = std::min(1.f, g * float(1.0 / (0.02 * cell_m))) / std::max(g, 1e-6f);
      const float style = rugged.empty() ? 1.f : rugged(y, x);
      const float d = style * w * amp_px * tile.sample(noise_u(y, x) * tpc + u0, noise_v(y, x) * tpc + v0);
      mx(y, x) = float(x) - d * gx(y, x) * k;
      my(y, x) = float(y) - d * gy(y, x) * k;
    }
  cv::Mat1f out;
  cv::remap(h, out, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x)
      if (h(y, x) > 0) h(y, x) = std::max(kLandFloorM, out(y, x));
}

// A model answer is smoother than a rendered island (an L1-trained network
// predicts the mean of the valleys it cannot place), so a cone would shed
// water radially and erosion on it carves few valleys. Relief proportional
// to the land's own relief (fBm, one feature per feature_m) gives the
// drainage somewhere to start, as the render's noise does for the generator;
// the coast (h → 0) does not move. The land's relief is its height over the
// lowest land within relief_reach_m (local_relief): on an island of the
// 6 km canvas, whose coast is within reach of nearly every cell, that is its
// height; on a wide gentle island of a world (20 km across, 3° slopes) it is
// what the slope builds over the reach, where relief ∝ height put bumps
// steeper than the island itself everywhere inland and the erosion left a
// crumpled surface without a valley network (docs/WORLDS.md).
void roughen_land(cv::Mat1f& h, double world_size_m, uint64_t seed, const AmplifyParams& p, const cv::Mat1f& rugged) {
  lobe_contours(h, world_size_m, seed, p, rugged);
  if (p.roughness <= 0) return;
  const int S = h.cols;
  const cv::Mat1f relief = local_relief(h, world_size_m / S, p.relief_reach_m);
  const NoiseTile& tile = NoiseTile::get(3);
  Rng rng(seed, 0, "amplify-rough");
  const float u0 = float(rng.uniform(0, NoiseTile::kSize)), v0 = float(rng.uniform(0, NoiseTile::kSize));
  const float texels_per_cell = float(NoiseTile::kBaseCell * world_size_m / (S * p.feature_m));
  const float a = float(p.roughness);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x)
      if (h(y, x) > 0) {
        const float style = rugged.empty() ? 1.f : rugged(y, x);
        // relief / height: exactly 1 where the reach meets the sea
        const float share = relief.empty() || relief(y, x) == h(y, x) ? 1.f : relief(y, x) / h(y, x);
        h(y, x) = std::max(kLandFloorM, h(y, x) * (1.f + style * a * share *
                                                            tile.sample(x * texels_per_cell + u0, y * texels_per_cell + v0)));
      }
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
  cv::Mat1f plain(S, S);
  cv::Mat1i island;
  const std::vector<float> peak = island_peaks(h, island);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      const float low = low_island_m > 0
                            ? std::clamp(float(2.0 - 2.0 * peak[size_t(island(y, x))] / low_island_m), 0.f, 1.f)
                            : 0.f;
      plain(y, x) = (label(y, x) >= 1 && label(y, x) <= 3) ? 1.f : (h(y, x) > 0 ? low : 0.f);
    }
  const MaskedBlur land = masked_blur(h, h > 0.f, sigma_px);
  const cv::Mat1f &bl = land.weight, &bh = land.sum;
  cv::GaussianBlur(plain, plain, cv::Size(0, 0), 0.5 * sigma_px, 0.5 * sigma_px, cv::BORDER_REPLICATE);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      if (h(y, x) <= 0 || bl(y, x) < 1e-3f) continue;
      const float smooth = bh(y, x) / bl(y, x);
      const float t = std::clamp(h(y, x) / 5.f, 0.f, 1.f) * plain(y, x);
      h(y, x) = std::max(kLandFloorM, h(y, x) + t * (smooth - h(y, x)));
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
          value.push_back(std::max(kLandFloorM, sum / float(k)));
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

// Underwater, below kGridFreeTopM, the field is smoothed by a Gaussian of
// half a model cell (σ = 0.5 · N/S px) over the water alone, blended in over
// the first metre below kGridFreeTopM: the cubic upsampling printed the
// model's 23.4 m grid as an N/S-px waffle on underwater slopes. Measured
// (`realism --reef --grid-period 8`, docs/examples/painted-sketch.png at
// 2049²): 9.2 cm and 69× its frequency ring before, 0.7 cm and 4.5× after.
// Down from −2 m to −0.5 m since the waffle showed at 1:1 on reef flats and
// shallow lagoons (docs/REEF.md "The shallows"); the land is left out of the
// blur, so the shallows beside a coast are not pulled up into a shelf. The
// land, the coast and the reef crest (finished afterwards) keep every detail.
constexpr float kGridFreeTopM = -0.5f;
constexpr float kGridFreeBlendM = 1.f;
// Then the sea floor gets what a smooth blur takes away, honestly: isotropic
// fractal relief of kSeaFloorGrainM (sand, rubble, talus) with features of
// a model cell and finer, so nothing at the grid's period stands out of its
// frequency ring.
constexpr double kSeaFloorGrainM = 0.08;
// px: the water's blur runs on a grid where its σ spans this many cells
// once it is wider (4097² and up from a 256² answer; wide_blur.hpp: the
// read back is within 0.2 % of the local relief).
constexpr double kGridWorkSigmaPx = 4;
void smooth_model_grid_underwater(cv::Mat1f& h, int model_side, uint64_t seed) {
  const double sigma = 0.5 * double(h.cols) / model_side;
  if (sigma < 0.75) return;
  const terrain::GradientNoise2 grain(derive_seed(seed, 0, "sea-floor-grain"));
  const float inv_cell = float(double(model_side) / h.cols);  // noise features per pixel: one per model cell
  // The water's own mean: land left out of the blur (normalised convolution),
  // so that shallows beside a coast are not pulled up into a shelf.
  // At 8192² σ is 16 px: above kGridWorkSigmaPx on a coarser grid.
  const MaskedBlur water = masked_blur(h, h < 0.f, sigma, kGridWorkSigmaPx);
  const cv::Mat1f &blur = water.sum, &wet = water.weight;
  for_each_row(h.rows, [&](int y) {
    float* r = h.ptr<float>(y);
    const float* b = blur.ptr<float>(y);
    const float* m = wet.ptr<float>(y);
    for (int x = 0; x < h.cols; ++x) {
      if (!(r[x] < kGridFreeTopM) || !(m[x] > 0.f)) continue;
      const float mean = b[x] / m[x];
      const float w = std::clamp((kGridFreeTopM - r[x]) / kGridFreeBlendM, 0.f, 1.f);
      const float t = smoothstep(w);
      // Never raised above kGridFreeTopM: no new shallows or specks of land.
      const float g = float(kSeaFloorGrainM) * grain.fbm(float(x) * inv_cell * 2.f, float(y) * inv_cell * 2.f, 3);
      r[x] = std::min(r[x] + t * (mean - r[x] + g), kGridFreeTopM);
    }
  });
}

// A smooth region erodes as harder rock: ρ' = ρ + (1 − r)(1 − ρ), so a
// smooth shield (r = 0) is fully resistant (K · hard_erodibility) and a
// rugged one (r = 1) keeps the regions' resistance.
cv::Mat1f harden(const cv::Mat1f& resistance, const cv::Mat1f& rugged) {
  if (rugged.empty()) return resistance;
  cv::Mat1f out = resistance.clone();
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) out(y, x) += (1.f - rugged(y, x)) * (1.f - out(y, x));
  return out;
}

}  // namespace

cv::Mat1f local_relief(const cv::Mat1f& h, double cell_m, double reach_m) {
  if (reach_m <= 0) return {};
  const int r = std::max(1, int(std::lround(reach_m / cell_m)));
  cv::Mat1f lowest, base;
  cv::erode(h, lowest, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * r + 1, 2 * r + 1)), cv::Point(-1, -1), 1,
            cv::BORDER_REPLICATE);
  // The square window's corners softened; a window reaching the sea keeps
  // the height itself (base 0), so such cells are roughened as before.
  cv::GaussianBlur(lowest, base, cv::Size(0, 0), 0.25 * r, 0.25 * r, cv::BORDER_REPLICATE);
  cv::Mat1f relief = h.clone();
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x)
      if (lowest(y, x) > 0 && h(y, x) > 0) relief(y, x) = std::clamp(h(y, x) - base(y, x), 0.f, h(y, x));
  return relief;
}

cv::Mat1f ruggedness_at(const cv::Mat1b& ruggedness, int side, double world_size_m) {
  if (ruggedness.empty()) return {};
  double lo = 255;
  cv::minMaxLoc(ruggedness, &lo);
  if (lo >= 255) return {};
  cv::Mat1f r;
  ruggedness.convertTo(r, CV_32F, 1.0 / 255);
  cv::resize(r, r, cv::Size(side, side), 0, 0, side < r.cols ? cv::INTER_AREA : cv::INTER_LINEAR);
  const double sigma = kStyleBlendM * side / world_size_m;
  // At 8192² σ is 546 px: the blur on a coarse grid (wide_blur.hpp).
  if (sigma >= 0.5) r = wide_gaussian_blur(r, sigma);
  return r;
}

cv::Mat1f amplify_heights(const cv::Mat1f& coarse_m, const cv::Mat1b& label, double world_size_m, uint64_t seed,
                          const AmplifyParams& a, bool lowland_relief, const cv::Mat1b& ruggedness) {
  const ErosionParams& p = a.erosion;
  if (coarse_m.empty() || coarse_m.rows != coarse_m.cols || label.rows != label.cols)
    throw Error("amplify: the height field and the label map must be square");
  const int S = coarse_m.cols, N = label.cols;
  cv::Mat1f coarse = coarse_m.clone();
  cv::Mat1b label_s;
  cv::resize(label, label_s, cv::Size(S, S), 0, 0, cv::INTER_NEAREST);
  const bool erode = N > S || a.erode_at_model_side;
  if (p.enabled && erode) smooth_plains(coarse, label_s, a.plain_smooth_m / (world_size_m / S), a.low_island_m);
  if (p.enabled) fill_ponds(coarse, label_s, world_size_m / S, a.pond_max_m2);
  const cv::Mat1f rugged_s = ruggedness_at(ruggedness, S, world_size_m);
  if (p.enabled && erode) {
    roughen_land(coarse, world_size_m, seed, a, rugged_s);
    // Few steps (AmplifyParams::steps, not the generator's `steps`): fewer
    // steps carve more valleys on the painted set (docs/notes/realism-history.md). The
    // drainage is routed once per step; our reading is that each re-routing
    // lets the deeper valleys capture the shallow ones the lobes started.
    erode_level(coarse, erodibility_map(harden(resistance_of_labels(label_s), rugged_s), seed, p), world_size_m / S,
                a.steps,
                p.duration_yr * a.duration_scale, p);
  }
  cv::Mat1f land = upsampled_within_cells(coarse, N);
  if (N <= S || !p.enabled) {
    if (N < S) cv::resize(coarse, land, cv::Size(N, N), 0, 0, cv::INTER_AREA);
    if (p.enabled) finish_painted_reef(land, label_s, world_size_m, seed);
    if (p.enabled) fill_ponds(land, label, world_size_m / N, a.pond_max_m2);
    drain_pits(land, kPitDepthM, float(p.pit_breach_m), world_size_m / N);
    if (p.enabled && lowland_relief) add_lowland_relief(land, 0, seed);
    grade_land(land, world_size_m / N);
    if (p.enabled) settle_motu(land, label_s, world_size_m, seed);
    return land;
  }
  auto detail = [&](int L, const cv::Mat1f& up) {
    cv::Mat1f d = fractal_detail(L, up, world_size_m, seed);
    const cv::Mat1f r = ruggedness_at(ruggedness, L, world_size_m);
    if (!r.empty()) d = d.mul(kSmoothDetailShare + (1.f - kSmoothDetailShare) * r);
    return d;
  };
  const cv::Mat1f resistance =
      harden(resampled(resistance_of_labels(label), N, cv::INTER_LINEAR), ruggedness_at(ruggedness, N, world_size_m));
  cv::Mat1f out = refine_heights(coarse, land, resistance, world_size_m, seed, p, detail);
  // Each finishing pass takes up to a second at 8192²: a host's stop
  // (Python's Ctrl-C, reefgen/interrupt.hpp) is read between them.
  check_interrupt();
  smooth_model_grid_underwater(out, S, seed);
  check_interrupt();
  finish_painted_reef(out, label_s, world_size_m, seed);
  grow_painted_patch_reefs(out, label_s, world_size_m, seed);
  check_interrupt();
  fill_ponds(out, label, world_size_m / N, a.pond_max_m2);
  check_interrupt();
  drain_pits(out, kPitDepthM, float(p.pit_breach_m), world_size_m / N);
  if (lowland_relief) add_lowland_relief(out, 0, seed);
  check_interrupt();
  grade_land(out, world_size_m / N);
  check_interrupt();
  settle_motu(out, label_s, world_size_m, seed);
  return out;
}

void add_lowland_relief(cv::Mat1f& h, int y0, uint64_t seed) {
  const NoiseTile& tile = NoiseTile::get(2);
  Rng rng(seed, 0, "lowland-relief");
  const float u0 = float(rng.uniform(0, NoiseTile::kSize)), v0 = float(rng.uniform(0, NoiseTile::kSize));
  const float texels_per_px = float(NoiseTile::kBaseCell) / kLowlandFeaturePx;
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      const float z = h(y, x);
      if (!(z > 0) || z >= kLowlandTopM) continue;
      const float n = tile.sample_cubic(float(x) * texels_per_px + u0, float(y0 + y) * texels_per_px + v0);
      h(y, x) = z + kLowlandReliefM * (1.f - z / kLowlandTopM) * 0.5f * (1.f + std::clamp(n, -1.f, 1.f));
    }
}

}  // namespace reefgen::infer
