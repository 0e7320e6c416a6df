#include "reefgen/terrain/pits.hpp"

#include <algorithm>
#include <cstring>
#include <cmath>
#include <limits>
#include <queue>
#include <unordered_map>
#include <vector>

#include "reefgen/error.hpp"
#include "reefgen/interrupt.hpp"
#include "reefgen/terrain/erosion.hpp"
#include "reefgen/terrain/flow.hpp"
#include "reefgen/terrain/noise.hpp"

namespace reefgen::terrain {

namespace {

// Min-heap items of the least-cost searches below: (key, cell) packed in 64
// bits, the key's float bits made an unsigned number in the float's own
// order (negatives flipped whole, positives with the sign bit set), ties by
// cell index — one integer compare per heap step, and a pure function. −0
// sorts just below +0 (the searches' keys are costs ≥ 0 and land heights > 0).
using HeapItem = uint64_t;
using MinHeap = std::priority_queue<HeapItem, std::vector<HeapItem>, std::greater<HeapItem>>;
inline HeapItem heap_item(float key, int cell) {
  uint32_t bits;
  std::memcpy(&bits, &key, sizeof bits);
  bits = (bits & 0x80000000u) ? ~bits : bits | 0x80000000u;
  return HeapItem(bits) << 32 | uint32_t(cell);
}
inline int heap_cell(HeapItem item) { return int(uint32_t(item)); }
inline float heap_key(HeapItem item) {
  uint32_t bits = uint32_t(item >> 32);
  bits = (bits & 0x80000000u) ? bits & 0x7FFFFFFFu : ~bits;
  float key;
  std::memcpy(&key, &bits, sizeof key);
  return key;
}

// grade_land's fall: kLandMinSlope to 1.85 times it (0.7–1.3 %), over
// features ~32 cells apart.
constexpr float kGradeVariation = 0.85f;
constexpr float kGradeFeaturePx = 32.f;

// Distance (m) from each depression cell (below its spill level) along the
// flood's path to the first cell that is not, and the index of that cell
// (the spill point): a forward sweep over the flood's order, where every
// receiver comes before its donors. -1 outside depressions.
struct SpillPaths {
  std::vector<float> dist_m;
  std::vector<int> spill_cell;
};
SpillPaths spill_paths(const FloodRoute& fr, const float* z, const float* spill, int cols, double cell_m) {
  const size_t n = fr.receiver.size();
  SpillPaths s{std::vector<float>(n, 0.f), std::vector<int>(n, -1)};
  for (const int i : fr.order) {
    if (!(z[i] < spill[i])) continue;
    const int r = fr.receiver[size_t(i)];
    if (r == i) continue;
    const bool diagonal = (i % cols != r % cols) && (i / cols != r / cols);
    const float step = float(cell_m * (diagonal ? M_SQRT2 : 1.0));
    const bool r_in = z[r] < spill[r] && s.spill_cell[size_t(r)] >= 0;
    s.spill_cell[size_t(i)] = r_in ? s.spill_cell[size_t(r)] : r;
    s.dist_m[size_t(i)] = (r_in ? s.dist_m[size_t(r)] : 0.f) + step;
  }
  return s;
}

// How much more a step over ground one metre above its depression's lowest
// cell costs than a step along that lowest ground (per metre of step): the
// least-cost route keeps to the depression's own valley floor.
constexpr double kRouteFlatCost = 0.05;

// Least-cost routes to the spill point inside each depression (Lindsay
// 2016's least-cost breaching, restricted to the depression): the flood's
// own route crosses a filled depression in straight rows and diagonals (its
// queue order on the flat fill), and a breach carved along it is a straight
// trench across whatever relief the depression holds. Dijkstra from every
// spill cell over the cells of its depression, a step costing its length
// times (kRouteFlatCost + height above the depression's lowest cell), gives
// each depression cell a receiver along its low ground and the length of
// that route (m). Outside depressions receiver is -1.
struct LowRoutes {
  std::vector<int> receiver;
  std::vector<float> dist_m;
};
LowRoutes low_routes(const SpillPaths& sp, const float* z, const float* spill, float max_depth_m, int cols, int rows,
                     double cell_m) {
  const size_t n = sp.spill_cell.size();
  LowRoutes r{std::vector<int>(n, -1), std::vector<float>(n, 0.f)};
  // Only depressions with a cell deeper than max_depth_m are drained; the
  // many shallower ones keep the flood's route (nothing walks it). low[s]:
  // the lowest height of the depression that spills at s (NaN: none).
  std::vector<float> low(n, std::numeric_limits<float>::quiet_NaN());
  std::vector<int> seeds;
  for (size_t i = 0; i < n; ++i)
    if (const int s = sp.spill_cell[i]; s >= 0 && z[i] > 0 && z[i] < spill[i] - max_depth_m) {
      if (std::isnan(low[size_t(s)])) seeds.push_back(s);
      low[size_t(s)] = std::isnan(low[size_t(s)]) ? z[i] : std::min(low[size_t(s)], z[i]);
    }
  // Costs in cell lengths (the same routes as in metres), ties by cell index
  // (heap_item), so the routes are deterministic.
  std::vector<float> cost(n, std::numeric_limits<float>::infinity());
  MinHeap queue;
  for (const int s : seeds) cost[size_t(s)] = 0, queue.push(heap_item(0.f, s));
  while (!queue.empty()) {
    const HeapItem top = queue.top();
    queue.pop();
    const int u = heap_cell(top);
    const float c = heap_key(top);
    if (c > cost[size_t(u)]) continue;
    // The spill cell is its depression's label; it lies outside the depression.
    const int label = sp.spill_cell[size_t(u)] >= 0 ? sp.spill_cell[size_t(u)] : u;
    const float floor_m = low[size_t(label)];
    const int uy = u / cols, ux = u % cols;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int y = uy + dy, x = ux + dx;
        if ((dx == 0 && dy == 0) || y < 0 || x < 0 || y >= rows || x >= cols) continue;
        const int v = y * cols + x;
        if (sp.spill_cell[size_t(v)] != label) continue;  // another depression, or none
        const float step = dx && dy ? float(M_SQRT2) : 1.f;
        const float next = c + step * (float(kRouteFlatCost) + std::max(0.f, z[v] - floor_m));
        if (next < cost[size_t(v)]) {
          cost[size_t(v)] = next;
          r.receiver[size_t(v)] = u;
          r.dist_m[size_t(v)] = r.dist_m[size_t(u)] + float(cell_m) * step;
          queue.push(heap_item(next, v));
        }
      }
  }
  return r;
}

// The banks of a breach: every cell within kBreachBankMaxPx of a cut cell c
// is lowered to at most z_c + kBreachBankSlope · distance, so the cut is a
// V-shaped notch with valley sides rather than a slot one cell wide.
void cut_banks(cv::Mat1f& h, const std::vector<int>& cut, const std::vector<float>& depth_m, double cell_m,
               std::vector<uint8_t>& moved) {
  const int W = h.cols, H = h.rows;
  const float rise_per_px = float(kBreachBankSlope * cell_m);
  for (size_t k = 0; k < cut.size(); ++k) {
    const int cy = cut[k] / W, cx = cut[k] % W;
    const float zc = h(cy, cx);
    const int r = std::min(kBreachBankMaxPx, int(std::ceil(depth_m[k] / rise_per_px)));
    for (int dy = -r; dy <= r; ++dy)
      for (int dx = -r; dx <= r; ++dx) {
        const int y = cy + dy, x = cx + dx;
        if (y < 0 || x < 0 || y >= H || x >= W || !(h(y, x) > 0)) continue;
        const float d = std::sqrt(float(dx * dx + dy * dy));
        if (d > float(r)) continue;
        if (zc + rise_per_px * d < h(y, x)) h(y, x) = zc + rise_per_px * d, moved[size_t(y * W + x)] = 1;
      }
  }
}

// grade_land over h (the land's box of the field, its top-left cell at
// `origin` of the field), counting the cells it raises: the least surface
// z ≥ h on which every land cell has a neighbour lower by its fall, found as
// Dijkstra's shortest paths from the sea with the keys the output heights
// (Barnes, Lehman & Mulla 2014's Priority-Flood+ε: the queue holds the
// raised values, not the input's). A sweep in the order of the input's own
// flood raised a low spot reached early along a long winding path and left
// the neighbours reached later along a short one lower: steps of 0.2–0.3 m
// along the borders between the two, a network of scarps over a graded
// coastal plain at 1:1.
int64_t grade_box(cv::Mat1f& h, cv::Point origin, double cell_m, double slope) {
  check_interrupt();
  const cv::Mat1b role = sea_and_edge_roles(h);
  if (!h.isContinuous()) h = h.clone();
  float* z = h.ptr<float>();
  const uint8_t* rl = role.ptr<uint8_t>();
  const int W = h.cols, H = h.rows;
  // The fall varies over the ground, `slope` to (1 + kGradeVariation) times
  // it, one feature every kGradeFeaturePx cells (of the field, wherever the
  // box lies): one fall everywhere made a graded plain a perfect cone, every
  // row of it one step apart.
  const NoiseTile& tile = NoiseTile::get(2);
  const float texels_per_px = float(NoiseTile::kBaseCell) / kGradeFeaturePx;
  // Each land cell's fall over one step, sampled once (the search relaxes a
  // cell from up to eight neighbours).
  std::vector<float> rise(h.total(), 0.f);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (rl[y * W + x] != kActive) continue;
      const float n = std::clamp(
          tile.sample_cubic(float(origin.x + x) * texels_per_px, float(origin.y + y) * texels_per_px), -1.f, 1.f);
      rise[size_t(y * W + x)] = float(slope * cell_m) * (1.f + kGradeVariation * 0.5f * (1.f + n));
    }
  // Items (height, flat index), ties by index (heap_item): the result is a
  // pure function.
  MinHeap open;
  std::vector<float> best(h.total(), std::numeric_limits<float>::infinity());
  std::vector<uint8_t> final_(h.total(), 0);
  // Land next to the sea (or the canvas edge) is at least the land's floor,
  // or its fall above edge land.
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int i = y * W + x;
      if (rl[i] != kActive) continue;
      const float fall = rise[size_t(i)];
      float least = std::numeric_limits<float>::infinity();
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int j = (y + dy) * W + x + dx;
          if ((dx == 0 && dy == 0) || rl[j] != kOutlet) continue;
          least = std::min(least, z[j] > 0 ? z[j] + fall * (dx != 0 && dy != 0 ? float(M_SQRT2) : 1.f) : kLandFloorM);
        }
      if (least == std::numeric_limits<float>::infinity()) continue;
      best[size_t(i)] = std::max(z[i], least);
      open.push(heap_item(best[size_t(i)], i));
    }
  int64_t raised = 0;
  while (!open.empty()) {
    const int i = heap_cell(open.top());
    open.pop();
    const float v = best[size_t(i)];
    if (final_[size_t(i)]) continue;
    final_[size_t(i)] = 1;
    if (z[i] < v) z[i] = v, ++raised;
    const int x = i % W, y = i / W;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int nx = x + dx, ny = y + dy, j = ny * W + nx;
        if ((dx == 0 && dy == 0) || rl[j] != kActive || final_[size_t(j)]) continue;
        const float c = std::max(z[j], v + rise[size_t(j)] * (dx != 0 && dy != 0 ? float(M_SQRT2) : 1.f));
        if (c < best[size_t(j)]) best[size_t(j)] = c, open.push(heap_item(c, j));
      }
  }
  return raised;
}

}  // namespace

int64_t grade_land(cv::Mat1f& h, double cell_m, double slope) {
  if (!(cell_m > 0) || !(slope >= 0)) throw Error("grade_land: the cell size must be > 0 m and the slope ≥ 0");
  // Islands cover a minority of the canvas: the land's box, with its ring of
  // sea (or the canvas edge), holds every cell graded and every outlet, and
  // the flood orders its cells as it would the whole field's.
  const cv::Rect box = land_box(h);
  if (box.empty()) return 0;
  cv::Mat1f sub = h(box).clone();
  const int64_t raised = grade_box(sub, box.tl(), cell_m, slope);
  sub.copyTo(h(box));
  return raised;
}

namespace {
// drain_pits over h (the land's box of the field). Long: fill and breach
// share the flood's depression labels and routes built at its top; the two
// stages are marked.
int64_t drain_box(cv::Mat1f& h, float max_depth_m, float breach_m, double cell_m) {
  check_interrupt();
  if (!h.isContinuous()) h = h.clone();
  const FloodRoute fr = flood_route(h, sea_and_edge_roles(h));
  const int n = h.rows * h.cols;
  float* z = h.ptr<float>();
  std::vector<uint8_t> moved(size_t(n), 0);
  const float* spill = fr.filled.ptr<float>();
  const bool valley = cell_m > 0;
  const float slope = valley ? float(kDrainFloorSlope) : 0.f;
  // Shaped like a valley: each depression's floor falls towards its spill
  // point at kDrainFloorSlope, lowest there, as high as the flat floor at the
  // depression's far end.
  SpillPaths paths;
  LowRoutes routes;
  std::unordered_map<int, float> longest_m;
  if (valley) {
    paths = spill_paths(fr, z, spill, h.cols, cell_m);
    routes = low_routes(paths, z, spill, max_depth_m, h.cols, h.rows, cell_m);
    for (int i = 0; i < n; ++i)
      if (z[i] > 0 && z[i] < spill[i] - max_depth_m && paths.spill_cell[size_t(i)] >= 0) {
        float& l = longest_m[paths.spill_cell[size_t(i)]];
        l = std::max(l, routes.dist_m[size_t(i)]);
      }
  }
  // Where water goes from cell i: along its depression's low ground when
  // shaped like a valley, else (and outside depressions) the flood's route.
  const auto next_of = [&](int i) {
    return valley && routes.receiver[size_t(i)] >= 0 ? routes.receiver[size_t(i)] : fr.receiver[size_t(i)];
  };
  // Filled: a closed depression deeper than breach_m is raised to breach_m
  // below its spill level (a lake floor; falling to the spill point when
  // shaped like a valley); what is left is breached below.
  const float lake_floor_m = std::max(max_depth_m, breach_m);
  std::vector<int> pits;
  for (int i = 0; i < n; ++i) {
    if (!(z[i] > 0 && z[i] < spill[i] - max_depth_m)) continue;
    float floor = spill[i] - lake_floor_m;
    if (valley && paths.spill_cell[size_t(i)] >= 0) {
      const float longest = longest_m[paths.spill_cell[size_t(i)]];
      // Near sea level the floor is left room to fall: a cut that reached the
      // land's floor would run on flat (a slot at 0.1 m to the sea).
      const float depth = std::clamp(spill[i] - kLandFloorM - float(kBreachRoomM) - slope * longest, max_depth_m,
                                     lake_floor_m);
      floor = spill[i] - depth - slope * (longest - routes.dist_m[size_t(i)]);
    }
    if (z[i] < floor) z[i] = floor, moved[size_t(i)] = 1;
    pits.push_back(i);
  }
  std::vector<int> cut;
  std::vector<float> cut_depth_m;
  if (breach_m > max_depth_m || valley) {
    // Breached (Lindsay 2016): a shallow depression keeps its own relief and
    // its outflow path is cut down instead. Filling it would leave a dead-flat
    // floor; behind a coast's thin rim these floors were a ring of flats
    // around every island (docs/EROSION.md). From the lowest depression cell
    // up, the flood's route to the outlet (through the spill point) is made
    // non-ascending by lowering the cells above the level carried along it —
    // falling kDrainFloorSlope a metre when shaped like a valley, so a breach
    // is never a flat canal. A walk stops on a cell an earlier, lower walk
    // already made drain: from there on the path is non-ascending below that
    // cell.
    std::sort(pits.begin(), pits.end(), [&](int a, int b) { return z[a] < z[b] || (z[a] == z[b] && a < b); });
    std::vector<uint8_t> drains(size_t(n), 0);
    for (const int i : pits) {
      float level = z[i];
      int from = i;
      for (int j = next_of(i); j != i;) {
        const bool diagonal = (from % h.cols != j % h.cols) && (from / h.cols != j / h.cols);
        // Never below the land's floor (kLandFloorM): on a low plain a fall
        // carried to the sea would cut a straight slot down to 0 m.
        const float target =
            std::max(level - slope * float(cell_m * (diagonal ? M_SQRT2 : 1.0)), std::min(level, kLandFloorM));
        if (drains[size_t(j)] && z[j] <= level) break;
        // Only where the route would rise or run level: a cut carried on down
        // ground that already falls (if gently) would trench a plain to the sea.
        if (valley ? z[j] >= level && z[j] > target : z[j] > level) {
          if (valley) cut.push_back(j), cut_depth_m.push_back(z[j] - target);
          z[j] = valley ? target : level;
          moved[size_t(j)] = 1;
        }
        level = z[j];
        drains[size_t(j)] = 1;
        const int next = next_of(j);
        if (next == j) break;  // an outlet: the sea or the canvas edge
        from = j;
        j = next;
      }
      drains[size_t(i)] = 1;
    }
  }
  if (valley) cut_banks(h, cut, cut_depth_m, cell_m, moved);
  int64_t changed = 0;
  for (const uint8_t m : moved) changed += m;
  return changed;
}
}  // namespace

// On the land's box, as grade_land: every pit, route and outlet lies in it
// (its ring is sea or the canvas edge, outlets either way), and the flood's
// ties go by flat index, in the same order in the box as in the field. At
// 8192² an island covers a few % of the canvas, and the flood over all of
// it took 1.5 s.
int64_t drain_pits(cv::Mat1f& h, float max_depth_m, float breach_m, double cell_m) {
  const cv::Rect box = land_box(h);
  if (box.empty()) return 0;
  if (box.size() == h.size()) return drain_box(h, max_depth_m, breach_m, cell_m);
  cv::Mat1f sub = h(box).clone();
  const int64_t changed = drain_box(sub, max_depth_m, breach_m, cell_m);
  sub.copyTo(h(box));
  return changed;
}

}  // namespace reefgen::terrain
