#include "reefgen/terrain/pits.hpp"

#include <algorithm>
#include <vector>

#include "reefgen/terrain/flow.hpp"

namespace reefgen::terrain {

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

}  // namespace reefgen::terrain
