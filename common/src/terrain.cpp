#include "reefgen/terrain.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <queue>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "reefgen/io.hpp"

namespace reefgen {

namespace {

// Heap entry: lowest height first, then lowest flat index (a total order, so
// the pop sequence never depends on the heap's internals), packed into one
// 64-bit key — the float's bits made order-preserving as unsigned, the index
// below — so each heap comparison is one integer compare (the heap is ~45 %
// of a dataset pair's time). −0 is folded onto +0: the two compare equal as
// floats, and the index must decide between them as before.
inline uint64_t node_key(float h, int i) {
  if (h == 0.0f) h = 0.0f;
  uint32_t u;
  std::memcpy(&u, &h, 4);
  u = (u & 0x80000000u) ? ~u : (u | 0x80000000u);
  return uint64_t(u) << 32 | uint32_t(i);
}
inline int node_index(uint64_t key) { return int(uint32_t(key)); }

// Priority-Flood's queue is monotone: every key pushed is above the last key
// popped (a cell enters the heap only when higher than the level it was
// reached from; lower cells go to the depression queue). A radix heap
// (Ahuja et al. 1990) is then exact: it pops the smallest key, as a binary
// heap does, so the pop order (and every drainage sum built on it) is the
// same, in O(1) per push and O(log C) amortised per pop instead of two
// O(log n) sift passes. Bucket b (1..64) holds keys whose highest bit
// differing from the last popped key is bit b − 1; a bit mask of the
// non-empty buckets finds the lowest in one instruction. Keys are unique (the
// cell index is in them), so no key pushed equals the last one popped and
// bucket 0 of the textbook structure is not needed.
class RadixHeap {
 public:
  bool empty() const { return mask_ == 0; }
  void push(uint64_t key) {
    if (key < last_) throw std::logic_error("flood_route: a key below the last popped one (the queue must be monotone)");
    put(key);
  }
  uint64_t pop() {
    const int b = __builtin_ctzll(mask_) + 1;
    std::vector<uint64_t>& v = buckets_[b];
    mask_ &= ~(1ull << (b - 1));
    if (v.size() == 1) {
      last_ = v[0];
      v.clear();
      return last_;
    }
    // The minimum leaves; every other key of the bucket now differs from it
    // below bit b − 1, so it moves to a lower bucket.
    const auto lowest = std::min_element(v.begin(), v.end());
    last_ = *lowest;
    *lowest = v.back();
    v.pop_back();
    for (const uint64_t k : v) put(k);
    v.clear();
    return last_;
  }

 private:
  void put(uint64_t key) {
    const uint64_t diff = key ^ last_;
    const int b = diff == 0 ? 1 : 64 - __builtin_clzll(diff);  // equal: only a repeated key, which sorts anywhere
    buckets_[b].push_back(key);
    mask_ |= 1ull << (b - 1);
  }
  std::vector<uint64_t> buckets_[65];
  uint64_t last_ = 0, mask_ = 0;
};

}  // namespace

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
  // division to find a cell's column), kSeeded = an outlet already queued.
  enum : uint8_t { kOpen = 1, kEdge = 2, kSeeded = 4 };
  std::vector<uint8_t> state(n);
  for (int i = 0; i < n; ++i) state[i] = rl[i] == kActive ? kOpen : 0;
  for (int x = 0; x < W; ++x) state[x] |= kEdge, state[(H - 1) * W + x] |= kEdge;
  for (int y = 0; y < H; ++y) state[y * W] |= kEdge, state[y * W + W - 1] |= kEdge;
  RadixHeap heap;
  // Depression cells: reached below the spill level, processed FIFO. Each
  // cell enters once; the buffer restarts whenever it runs empty.
  std::vector<int> pit;
  size_t pit_head = 0;
  static constexpr int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1}, kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  int offset[8];
  for (int k = 0; k < 8; ++k) offset[k] = kDy[k] * W + kDx[k];
  // Seeds: outlets next to an active cell (an outlet surrounded by outlets
  // routes nothing), found from the active side: islands are a minority of
  // the canvas. The order they are pushed in does not matter: keys are unique
  // and the heap pops the smallest.
  for (int i = 0; i < n; ++i) {
    if (rl[i] != kActive) continue;
    const bool interior = !(state[i] & kEdge);
    const int x = interior ? 0 : i % W, y = interior ? 0 : i / W;
    for (int k = 0; k < 8; ++k) {
      int j;
      if (interior) {
        j = i + offset[k];
      } else {
        const int nx = x + kDx[k], ny = y + kDy[k];
        if (nx < 0 || ny < 0 || nx >= W || ny >= H) continue;
        j = ny * W + nx;
      }
      if (rl[j] != kOutlet || (state[j] & kSeeded)) continue;
      state[j] |= kSeeded;
      heap.push(node_key(f[j], j));
    }
  }
  out.order.reserve(n);
  while (!heap.empty() || pit_head < pit.size()) {
    int c;
    if (pit_head < pit.size()) {
      c = pit[pit_head++];
      if (pit_head == pit.size()) pit.clear(), pit_head = 0;
    } else {
      c = node_index(heap.pop());
    }
    if (rl[c] == kActive) out.order.push_back(c);  // popped: its receiver was popped before it
    const bool interior = !(state[c] & kEdge);
    const int cx = interior ? 0 : c % W, cy = interior ? 0 : c / W;
    const float level = f[c];
    for (int k = 0; k < 8; ++k) {
      int j;
      if (interior) {
        j = c + offset[k];
      } else {
        const int nx = cx + kDx[k], ny = cy + kDy[k];
        if (nx < 0 || ny < 0 || nx >= W || ny >= H) continue;
        j = ny * W + nx;
      }
      if (!(state[j] & kOpen)) continue;
      state[j] &= uint8_t(~kOpen);
      out.receiver[j] = c;
      if (f[j] <= level) {
        f[j] = level;  // inside a depression: filled to the spill level
        pit.push_back(j);
      } else {
        heap.push(node_key(f[j], j));
      }
    }
  }
  return out;
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

void plan_curvature(const cv::Mat1f& s, double metres_per_px, cv::Mat1f& curvature, cv::Mat1f& gradient) {
  const int H = s.rows, W = s.cols;
  curvature.create(H, W);
  gradient.create(H, W);
  const double d = metres_per_px;
  for (int y = 0; y < H; ++y) {
    const int ym = std::max(y - 1, 0), yp = std::min(y + 1, H - 1);
    for (int x = 0; x < W; ++x) {
      const int xm = std::max(x - 1, 0), xp = std::min(x + 1, W - 1);
      // Image rows grow downwards; the curvature's sign does not depend on
      // the y orientation (h_y appears squared or with h_xy, which flips too).
      const double hx = (s(y, xp) - s(y, xm)) / ((xp - xm) * d);
      const double hy = (s(yp, x) - s(ym, x)) / ((yp - ym) * d);
      const double hxx = (s(y, xp) - 2.0 * s(y, x) + s(y, xm)) / (d * d);
      const double hyy = (s(yp, x) - 2.0 * s(y, x) + s(ym, x)) / (d * d);
      const double hxy = (s(yp, xp) - s(yp, xm) - s(ym, xp) + s(ym, xm)) / (4.0 * d * d);
      const double g2 = hx * hx + hy * hy;
      gradient(y, x) = static_cast<float>(std::sqrt(g2));
      curvature(y, x) = g2 > 0 ? static_cast<float>(-(hxx * hy * hy - 2.0 * hxy * hx * hy + hyy * hx * hx) /
                                                    std::pow(g2, 1.5))
                               : 0.f;
    }
  }
}

RealismStats realism_stats(const cv::Mat1f& h, double metres_per_px) {
  if (h.empty()) throw Error("realism: the height field is empty");
  if (!(metres_per_px > 0) || !std::isfinite(metres_per_px))
    throw Error("realism: metres per pixel must be a positive number");
  if (!cv::checkRange(h)) throw Error("realism: the height field holds NaN or infinite values");
  const cv::Mat1f hc = h.isContinuous() ? h : h.clone();
  const int H = hc.rows, W = hc.cols;
  RealismStats st;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (hc(y, x) > 0) {
        ++st.land_cells;
        st.max_height_m = std::max(st.max_height_m, double(hc(y, x)));
      }
  if (st.land_cells == 0) return st;

  // Pits: filled from the sea and the canvas edge.
  const FloodRoute fr = flood_route(hc, sea_and_edge_roles(hc));
  int64_t pits = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (hc(y, x) > 0 && fr.filled(y, x) - hc(y, x) > 1.f) ++pits;
  st.pits = double(pits) / double(st.land_cells);

  // Flank, slope on the raw heights; curvature on the σ = 60 m smoothed heights.
  const double lo = 0.1 * st.max_height_m, hi = 0.9 * st.max_height_m;
  const double sigma_px = 60.0 / metres_per_px;
  cv::Mat1f smooth;
  cv::GaussianBlur(hc, smooth, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  cv::Mat1f curv, grad_s, curv_raw, grad_raw;
  plan_curvature(smooth, metres_per_px, curv, grad_s);
  plan_curvature(hc, metres_per_px, curv_raw, grad_raw);
  const double flat = std::tan(2.0 * M_PI / 180.0);
  int64_t flats = 0, valleys = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double v = hc(y, x);
      if (!(v > 0 && v >= lo && v <= hi)) continue;
      ++st.flank_cells;
      if (grad_raw(y, x) < flat) ++flats;
      if (grad_s(y, x) > 0.02 && curv(y, x) < -1e-3) ++valleys;
    }
  if (st.flank_cells > 0) {
    st.terraces = double(flats) / double(st.flank_cells);
    st.valleys = double(valleys) / double(st.flank_cells);
  }
  return st;
}

}  // namespace reefgen
