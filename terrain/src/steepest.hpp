#pragma once
// The per-cell scan both routers share: the 8 slopes of a cell, its steepest
// lower neighbour and the sum of its squared downhill slopes, for the
// interior cells of one row at a time, dispatched to the CPU's vector path
// (reefgen/vector_path.hpp). Internal to terrain/.
#include <cstdint>

namespace reefgen::terrain {

// For the cells x in [1, W − 2] of a row that has a row above and below it
// (z and role point at the row's first cell, rows W apart), the neighbour k
// (kDx/kDy order) each cell drains to, −1 where none is lower:
// - draw == nullptr: the largest slope (z − z_k)·inv[k] > 0 among the
//   neighbours whose role is not kIgnore, the first one on ties (D8);
// - else draw[x] ∈ [0, 1): where Σ slope² (over the lower open neighbours,
//   in k order) is > 0, the first k whose running sum exceeds draw[x]·Σ,
//   skipping zero weights (route_stack's random receivers); D8 elsewhere.
// Exactly what the scalar loops over k give, on every path.
using SteepestRowFn = void (*)(const float* z, const uint8_t* role, int W, const float inv[8], const float* draw,
                               int8_t* receiver_k);
SteepestRowFn steepest_row();

}  // namespace reefgen::terrain
