#pragma once
// Facts several stages rely on, named once (docs/DESIGN.md §2, §5).

namespace reefgen {

// Width of the [-1, 1] canvas every sketch and generated island covers, m:
// the default of IslandSpec::world_size_m, infer/eval's --world-size and the
// metres per pixel of every export whose source carries no size.
inline constexpr double kCanvasWorldSizeM = 6000;

// The height range the networks map to [-1, 1], m: the abyss floor and a
// ceiling above every generated peak of the shipped datasets.
inline constexpr double kAbyssFloorM = -100;
inline constexpr double kHeightCeilingM = 560;

}  // namespace reefgen
