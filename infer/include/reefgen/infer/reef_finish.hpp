#pragma once
// A painted reef finished from its zones (docs/REEF.md "Painted reefs"): the
// model's 23.4 m cells cannot hold a crest a few cells wide at sea level or a
// motu of a few cells, and L1 training blurs both into their deeper
// surroundings. Coral keeps up with subsidence (that is what a living reef
// is), so inside the painted reef ring the reef top is grown back to the
// generator's crest and reef flat, and small painted islets on the ring are
// raised as motu. It lifts, except land the model left on the reef band,
// just off it and on the painted open sea, eased off painted shores and
// motu, which goes awash (the generator's
// crest is awash; the network's, a chain of land beads); a painted gap (a
// pass) or the lagoon is never touched. LibTorch-free.
#include <cstdint>

#include <opencv2/core.hpp>

namespace reefgen::infer {

struct PaintedReefParams {
  // The reef top the generator builds (procgen CoralParams crest_m / flat_m; a test keeps them equal).
  double crest_m = -0.3;          // crest height, metres, [-5, 0]
  double flat_m = -0.8;           // reef flat behind it, metres, [-5, 0]
  // Where the top lies across the painted ring, as the share t of the way
  // from its seaward edge (0) to its lagoon or land edge (1); measured on the
  // generator's own training pairs: crest at t 0.2-0.32, flat to 0.5, back
  // reef below (docs/REEF.md).
  double crest_begin = 0.22;      // t where the crest reaches its height, [0, 1]
  double flat_end = 0.5;          // t where the flat starts to give way to the back reef, [0, 1]
  double top_relief_m = 0.25;     // irregularity of the crest and flat, metres, [0, 1]
  // Seaward of the crest the fore reef descends from it to this depth at the
  // painted band's seaward edge (the generator's reef label ends at −3…−20 m),
  // linearly across the band, where the network left a shelf (−3…−7 m, ~100 m
  // wide, then a 60 m drop: a ring round every wide painted reef).
  double fore_edge_m = -15;       // fore reef depth at the band's seaward edge, metres, [-60, 0]
  // Motu: islets of painted beach or island wholly on the ring.
  double motu_height_m = 2.5;     // berm height, metres, [0.5, 5] (real motu 1-4 m, docs/REEF.md)
  double motu_max_width_m = 500;  // a wider painted islet is an island, left to the model, m (real 263 ± 210), > 0
  double motu_max_area_m2 = 2e6;  // so is a larger one, m², > 0
};

// t across the painted reef at the label's side, in [0, 1] everywhere: 0 on
// the open sea, 1 on lagoon and land (islets counted as reef). Also the
// islet mask (255 on motu cells). label: regions (labels.hpp), square.
cv::Mat1f reef_position(const cv::Mat1b& label, const PaintedReefParams& p, double world_size_m, cv::Mat1b& motu);

// Lifts h (any side, square) to the painted reef's top and motu, and lowers
// the land on and off the reef band to that top, eased off painted land. label:
// the regions at the model's side (amplify_heights' label_s).
void finish_painted_reef(cv::Mat1f& h, const cv::Mat1b& label, double world_size_m, uint64_t seed,
                         const PaintedReefParams& p = {});

// The painted motu's inside, after the land is graded (docs/REEF.md "Motu"):
// no higher than a berm of motu_height_m along its shore and a flat at that
// height behind it with swales (real motu 1–4 m). The graded fall towards the sea
// (terrain::grade_land) raised a wide motu into a 5–7 m dome, and the
// network's answer to a painted dot can stand higher; sand drains into the
// ground, so a motu needs no fall. Only lowers, only inside the islets
// finish_painted_reef raised. label: the regions at the model's side.
void settle_motu(cv::Mat1f& h, const cv::Mat1b& label, double world_size_m, uint64_t seed,
                 const PaintedReefParams& p = {});

// Patch reefs on the painted lagoon's floor (docs/REEF.md "Painted
// lagoons"). The training targets' lagoons hold patch reefs at random places
// the sketch does not show, so an L1-trained network answers their average:
// a floor without knolls. Where the output is finer than the model's side,
// they come back by the generator's own rule (terrain/patch_reefs.hpp
// patch_reef_m: knolls where a noise of ~250 m features passes a threshold
// set by `patch_reefs`, tops 0.5–6 m under water), on painted lagoon floor
// below −2 m, only lifting it. label: regions at any side (nearest), square.
struct PaintedLagoonParams {
  double patch_reefs = 0.3;   // how much of the floor rises in patch reefs (the generator's default), [0, 1]
};
void grow_painted_patch_reefs(cv::Mat1f& h, const cv::Mat1b& label, double world_size_m, uint64_t seed,
                              const PaintedLagoonParams& p = {});

}  // namespace reefgen::infer
