#pragma once
// Facts several stages rely on, named once (docs/DESIGN.md §2, §5).

namespace reefgen {

// Width of the [-1, 1] canvas every sketch and generated island covers, m:
// the default of IslandSpec::world_size_m, infer/eval's --world-size and the
// metres per pixel of every export whose source carries no size.
inline constexpr double kCanvasWorldSizeM = 6000;
// The side of the model's input and output, px, and so the metres of one
// sketch pixel at the model's own scale (kCanvasWorldSizeM / kModelSidePx =
// 23.4 m): a world sketch is read at this scale unless the user says otherwise.
inline constexpr int kModelSidePx = 256;
inline constexpr double kModelMetresPerPx = kCanvasWorldSizeM / kModelSidePx;

// The height range the networks map to [-1, 1], m: the abyss floor and a
// ceiling above every generated peak of the shipped datasets.
inline constexpr double kAbyssFloorM = -100;
inline constexpr double kHeightCeilingM = 560;

// Sides of one height field, px: the generator draws down to 8² (tests use
// tiny islands); inference needs 16² (the U-Net's stride before amplifying);
// 8192² is where one field with its working copies stays under ~4 GB.
// The libraries check them; the CLI and the studio report what they say.
inline constexpr int kMinGenerateSidePx = 8;
inline constexpr int kMinInferSidePx = 16;
inline constexpr int kMaxSidePx = 8192;
// The largest side any user image is decoded at, px, checked from its header
// first: 16384² RGBA is 1 GiB (the studio and erode set lower limits).
inline constexpr int kMaxImageSidePx = 16384;
// The largest height field read whole, px: a world's 16385² field (1 GiB of
// floats); a file declaring more is refused from its header.
inline constexpr int kMaxFieldSidePx = 16385;

}  // namespace reefgen
