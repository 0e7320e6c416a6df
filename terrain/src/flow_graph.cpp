#include <cmath>
#include <vector>

#include "reefgen/rng.hpp"
#include "reefgen/terrain/flow.hpp"
#include "neighbours.hpp"
#include "steepest.hpp"

namespace reefgen::terrain {

namespace {

// The donor tree walked breadth-first from each base level (a cell that is
// its own receiver and drains something): receivers come before donors.
void stack_from_receivers(const std::vector<int>& recv, std::vector<int>& order) {
  const int n = static_cast<int>(recv.size());
  std::vector<int> ndon(n + 1, 0);
  for (int i = 0; i < n; ++i)
    if (recv[i] != i) ++ndon[recv[i] + 1];
  for (int i = 0; i < n; ++i) ndon[i + 1] += ndon[i];
  std::vector<int> donors(ndon[n]), fill(ndon.begin(), ndon.end() - 1);
  for (int i = 0; i < n; ++i)
    if (recv[i] != i) donors[fill[recv[i]]++] = i;
  order.clear();
  for (int i = 0; i < n; ++i) {
    if (recv[i] != i || ndon[i + 1] == ndon[i]) continue;  // not a base level, or drains nothing
    const size_t start = order.size();
    for (int k = ndon[i]; k < ndon[i + 1]; ++k) order.push_back(donors[k]);
    for (size_t head = start; head < order.size(); ++head) {
      const int c = order[head];
      for (int k = ndon[c]; k < ndon[c + 1]; ++k) order.push_back(donors[k]);
    }
  }
}

}  // namespace

void route_flood(const cv::Mat1f& height_m, const cv::Mat1b& role, double metres_per_px, FlowGraph& g) {
  FloodRoute fr = flood_route(height_m, role);
  const int W = height_m.cols;
  const StepLengths len(metres_per_px);
  int offset[8];
  for (int d = 0; d < 8; ++d) offset[d] = kDy[d] * W + kDx[d];
  const float* fz = fr.filled.ptr<float>();
  g.receiver = std::move(fr.receiver);
  g.inv_length.assign(g.receiver.size(), 0.f);
  // Lower neighbours were taken out of the flood's queues first, so the
  // steepest descent on the filled surface is a receiver that comes earlier
  // in the order; where none is lower, the flood's own receiver stays.
  // Receivers do not depend on the order: the cells are visited in memory
  // order (the flood's order jumps about the grid; 3 % of `bench generate`).
  const uint8_t* rl = role.ptr<uint8_t>();
  for (int i = 0; i < int(g.receiver.size()); ++i) {
    if (rl[i] != kActive) continue;
    int best = g.receiver[i];
    const int step = best - i;
    float best_s = 0.f, best_l = (step == 1 || step == -1 || step == W || step == -W) ? len.axial : len.diagonal;
    for (int d = 0; d < 8; ++d) {
      const float sl = (fz[i] - fz[i + offset[d]]) * len.inv[d];
      if (sl > best_s) best_s = sl, best = i + offset[d], best_l = len.inv[d];
    }
    g.receiver[i] = best;
    g.inv_length[i] = best_l;
  }
  g.stack = std::move(fr.order);
  g.surface = fr.filled;
}

namespace {

// Where in [0, 1) cell i's random receiver is drawn (route_stack's salt).
float draw_fraction(uint64_t salt, uint64_t i) { return float(mix64(salt ^ mix64(i)) >> 40) * (1.f / 16777216.f); }

// The scalar scan of one cell, for the canvas-edge cells (the interior rows
// go through steepest_row, which gives the same answers).
struct CellScan {
  const float* z;
  const uint8_t* rl;
  int W, H;
  const StepLengths& len;
  uint64_t salt;

  // Cell i's receiver direction k, −1 for none: the steepest lower open
  // neighbour (D8); with a salt, a lower one drawn ∝ slope² where any is.
  int receiver_k(int i) const {
    const int x = i % W, y = i / W;
    float best_s = 0.f, sum = 0.f, w[8];
    int best = -1;
    for (int k = 0; k < 8; ++k) {
      w[k] = 0.f;
      const int nx = x + kDx[k], ny = y + kDy[k];
      if (nx < 0 || ny < 0 || nx >= W || ny >= H) continue;
      const int j = ny * W + nx;
      if (rl[j] == kIgnore) continue;
      const float sl = (z[i] - z[j]) * len.inv[k];
      if (sl > 0.f) sum += (w[k] = sl * sl);
      if (sl > best_s) best_s = sl, best = k;
    }
    if (salt == 0 || !(sum > 0.f)) return best;
    const float u = draw_fraction(salt, uint64_t(i)) * sum;
    float c = 0.f;
    for (int k = 0; k < 8; ++k) {
      if (w[k] <= 0.f) continue;
      c += w[k];
      best = k;
      if (u < c) break;
    }
    return best;
  }

  // k (or −1: the cell is its own receiver) → receiver and 1/length.
  void set(int i, int k, FlowGraph& g) const {
    if (k < 0) return;
    g.receiver[i] = i + kDy[k] * W + kDx[k];
    g.inv_length[i] = len.inv[k];
  }
};

}  // namespace

void route_stack(const cv::Mat1f& height_m, const cv::Mat1b& role, double metres_per_px, uint64_t salt,
                 FlowGraph& g) {
  const int W = height_m.cols, H = height_m.rows, n = W * H;
  const StepLengths len(metres_per_px);
  const CellScan scan{height_m.ptr<float>(), role.ptr<uint8_t>(), W, H, len, salt};
  g.receiver.resize(n);
  g.inv_length.resize(n);
  for (int i = 0; i < n; ++i) g.receiver[i] = i;
  auto scalar_cell = [&](int i) {
    if (scan.rl[i] == kActive) scan.set(i, scan.receiver_k(i), g);
  };
  // The interior rows: the 8-neighbour scan and the draw on the CPU's
  // vector path (the hashes first, scalar); the edges scalar.
  const SteepestRowFn steepest = steepest_row();
  std::vector<int8_t> receiver_k(W);
  std::vector<float> draw(salt != 0 ? W : 0);
  for (int y = 0; y < H; ++y) {
    const int row = y * W;
    if (y == 0 || y == H - 1 || W < 3) {
      for (int x = 0; x < W; ++x) scalar_cell(row + x);
      continue;
    }
    for (size_t x = 0; x < draw.size(); ++x)
      draw[x] = draw_fraction(salt, uint64_t(row) + x);
    steepest(scan.z + row, scan.rl + row, W, len.inv, draw.empty() ? nullptr : draw.data(), receiver_k.data());
    scalar_cell(row);
    for (int x = 1; x < W - 1; ++x)
      if (scan.rl[row + x] == kActive) scan.set(row + x, receiver_k[x], g);
    scalar_cell(row + W - 1);
  }
  stack_from_receivers(g.receiver, g.stack);
  g.surface = height_m;
}

}  // namespace reefgen::terrain
