#include "reefgen/terrain/flow.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <queue>
#include <stdexcept>

#include <opencv2/imgproc.hpp>


namespace reefgen::terrain {

namespace {

// Queue order: lowest height first, then lowest flat index (a total order, so
// the route is a pure function of the inputs), packed into one 64-bit key —
// the float's bits made order-preserving as unsigned, the index below. −0 is
// folded onto +0: the two compare equal as floats, and the index must decide
// between them.
inline uint32_t height_key(float h) {
  if (h == 0.0f) h = 0.0f;
  uint32_t u;
  std::memcpy(&u, &h, 4);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}
inline uint64_t node_key(float h, int i) { return uint64_t(height_key(h)) << 32 | uint32_t(i); }
inline int node_index(uint64_t key) { return int(uint32_t(key)); }

// Sorts keys by their upper 32 bits, stably (ties keep their input order):
// LSD radix sort, three passes of 11, 11 and 10 bits, a pass skipped when all
// keys share its digit.
void sort_by_height_key(std::vector<uint64_t>& keys) {
  std::vector<uint64_t> tmp(keys.size());
  static constexpr int kShift[3] = {32, 43, 54}, kBuckets = 2048;
  std::vector<uint32_t> count(3 * kBuckets, 0);
  for (const uint64_t k : keys)
    for (int p = 0; p < 3; ++p) ++count[p * kBuckets + ((k >> kShift[p]) & (kBuckets - 1))];
  for (int p = 0; p < 3; ++p) {
    uint32_t* c = &count[p * kBuckets];
    if (!keys.empty() && c[(keys[0] >> kShift[p]) & (kBuckets - 1)] == keys.size()) continue;
    uint32_t sum = 0;
    for (int b = 0; b < kBuckets; ++b) {
      const uint32_t here = c[b];
      c[b] = sum;
      sum += here;
    }
    for (const uint64_t k : keys) tmp[c[(k >> kShift[p]) & (kBuckets - 1)]++] = k;
    keys.swap(tmp);
  }
}

}  // namespace

// One function on purpose: the flood's state, its two queues and the
// neighbour walk are touched for every cell in the hot loop; as separate
// functions they would be passed around per cell. Its steps are marked below.
FloodRoute flood_route(const cv::Mat1f& height, const cv::Mat1b& role) {
  CV_Assert(height.size() == role.size() && height.isContinuous() && role.isContinuous());
  const int H = height.rows, W = height.cols, n = H * W;
  FloodRoute out;
  out.receiver.resize(n);
  for (int i = 0; i < n; ++i) out.receiver[i] = i;
  out.filled = height.clone();
  const uint8_t* rl = role.ptr<uint8_t>();
  float* f = out.filled.ptr<float>();
  // state[i]: kOpen = an active cell the flood has not reached yet (the one
  // test per neighbour in the loop below), kEdge = on the canvas edge (the
  // only cells whose neighbours need bounds checks; the others go through
  // flat-index offsets: the same neighbours in the same order, and no
  // division to find a cell's column), kQueued = in the priority queue
  // (a seed, or a cell reached from below).
  enum : uint8_t { kOpen = 1, kEdge = 2, kQueued = 4 };
  std::vector<uint8_t> state(n);
  for (int i = 0; i < n; ++i) state[i] = rl[i] == kActive ? kOpen : 0;
  for (int x = 0; x < W; ++x) state[x] |= kEdge, state[(H - 1) * W + x] |= kEdge;
  for (int y = 0; y < H; ++y) state[y * W] |= kEdge, state[y * W + W - 1] |= kEdge;
  // Depression cells: reached below the spill level, processed FIFO. Each
  // cell enters once; the buffer restarts whenever it runs empty.
  std::vector<int> pit;
  size_t pit_head = 0;
  static constexpr int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1}, kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  int offset[8];
  for (int k = 0; k < 8; ++k) offset[k] = kDy[k] * W + kDx[k];
  // visit(j) for each of c's neighbours inside the canvas, in kDx/kDy
  // order: flat-index offsets inside, bounds checks on the edge.
  auto for_neighbours = [&](int c, auto&& visit) {
    if (!(state[c] & kEdge)) {
      for (int k = 0; k < 8; ++k) visit(c + offset[k]);
      return;
    }
    const int cx = c % W, cy = c / W;
    for (int k = 0; k < 8; ++k) {
      const int nx = cx + kDx[k], ny = cy + kDy[k];
      if (nx >= 0 && ny >= 0 && nx < W && ny < H) visit(ny * W + nx);
    }
  };
  // Seeds: outlets next to an active cell (an outlet surrounded by outlets
  // routes nothing), found from the active side: islands are a minority of
  // the canvas.
  for (int i = 0; i < n; ++i)
    if (rl[i] == kActive)
      for_neighbours(i, [&](int j) {
        if (rl[j] == kOutlet) state[j] |= kQueued;
      });
  // The priority queue without a heap. Its keys are monotone: a cell is
  // queued only when strictly higher than the level it was reached from, and
  // that level is never below the last key taken out (lower cells go to the
  // depression queue). So every cell that will ever be queued can be sorted
  // up front (the seeds and the active cells), and "take the smallest queued
  // key" is a pointer walking that sorted list to the next cell that is
  // queued. A cell the pointer passes unqueued is lower than everything
  // still to come: if the flood reaches it later, it is a depression cell.
  // Same pop order as a binary heap (test Flood.RouteEqualsABinaryHeapPriorityFlood),
  // in O(n): a radix sort and one pass.
  std::vector<uint64_t> sorted;
  for (int i = 0; i < n; ++i)
    if (state[i] & (kOpen | kQueued)) sorted.push_back(node_key(f[i], i));
  sort_by_height_key(sorted);
  size_t next = 0;
  uint64_t last = 0;  // the last key the queue gave
  out.order.reserve(n);
  for (;;) {
    int c;
    if (pit_head < pit.size()) {
      c = pit[pit_head++];
      if (pit_head == pit.size()) pit.clear(), pit_head = 0;
    } else {
      while (next < sorted.size() && !(state[node_index(sorted[next])] & kQueued)) ++next;
      if (next == sorted.size()) break;
      last = sorted[next++];
      c = node_index(last);
    }
    if (rl[c] == kActive) out.order.push_back(c);  // taken out: its receiver was taken out before it
    const float level = f[c];
    for_neighbours(c, [&](int j) {
      if (!(state[j] & kOpen)) return;
      state[j] &= uint8_t(~kOpen);
      out.receiver[j] = c;
      if (f[j] <= level) {
        f[j] = level;  // inside a depression: filled to the spill level
        pit.push_back(j);
      } else {
        // Only a NaN height breaks the monotone order (it compares false).
        if (node_key(f[j], j) < last)
          throw std::logic_error("flood_route: a queued key below the last one taken (NaN height?)");
        state[j] |= kQueued;
      }
    });
  }
  return out;
}

cv::Rect land_box(const cv::Mat1f& h) {
  int x0 = h.cols, y0 = h.rows, x1 = -1, y1 = -1;
  for (int y = 0; y < h.rows; ++y) {
    const float* r = h.ptr<float>(y);
    for (int x = 0; x < h.cols; ++x)
      if (r[x] > 0) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  }
  if (x1 < 0) return {};
  return cv::Rect(cv::Point(std::max(0, x0 - 1), std::max(0, y0 - 1)),
                  cv::Point(std::min(h.cols, x1 + 2), std::min(h.rows, y1 + 2)));
}

cv::Mat1b sea_and_edge_roles(const cv::Mat1f& height_m, float sea_m) {
  const int H = height_m.rows, W = height_m.cols;
  cv::Mat1b role(H, W);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const bool edge = x == 0 || y == 0 || x == W - 1 || y == H - 1;
      role(y, x) = (edge || height_m(y, x) <= sea_m) ? kOutlet : kActive;
    }
  return role;
}

}  // namespace reefgen::terrain
