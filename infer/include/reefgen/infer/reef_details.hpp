#pragma once
// Seeded passes and motu on a painted reef ring (docs/REEF.md "Seeded passes
// and motu"). The network draws passes and motu only where the painting
// shows them (a gap in the reef band, green dots on it): the generator's
// training islands place theirs at random, so the sketch's label is all the
// network can follow. A re-rolled island (variation > 0, the default) gets
// them where the painting is silent, by the generator's rules: on a reef
// ring with a lagoon behind it and no painted pass, passes on the leeward
// side; on a ring without painted islets, motu on the reef flat, fewer on a
// young fringing reef. Each seed places its own; variation 0 places none.
// Positions are in metres, so the same plan paints any side. LibTorch-free.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace reefgen::infer {

// Passes per ring: the generator's random_passes (procgen ReefParams), one on
// a ring shorter than kTwoPassRingM.
inline constexpr int kSeededPasses = 2;
inline constexpr double kTwoPassRingM = 6000;
// Motu per metre of ring: the generator's 6 random motu on its typical atoll
// rim of ~14 km (a 2.2 km radius on the 6 km canvas), scaled down below
// subsidence kMotuFullSubsidence as the generator does.
inline constexpr double kSeededMotuPerM = 6.0 / 14000.0;
inline constexpr double kMotuFullSubsidence = 0.2;

struct SeededReefDetails {
  struct Pass {
    std::vector<cv::Point2d> path_m;  // centre line, lagoon side first, metres from the canvas's top-left corner
    double width_m = 0;               // full width (real passes tens of metres to ~1 km; the generator 100–260 m)
    double depth_m = 0;               // floor below sea level, m (the generator 8–20 m)
    // Where it crosses the middle of the ring (an odd number of points).
    cv::Point2d middle_m() const { return path_m.empty() ? cv::Point2d() : path_m[path_m.size() / 2]; }
  };
  struct Islet {
    cv::Point2d centre_m;
    double angle_rad = 0;   // direction of the long axis (along the ring)
    double half_len_m = 0;  // 75–600 m (Johnson & Ortiz: motu 263 ± 210 m wide)
    double half_wid_m = 0;  // at most 30 % of the ring's width there
  };
  std::vector<Pass> passes;
  std::vector<Islet> motu;
  bool empty() const { return passes.empty() && motu.empty(); }
};

// The plan for one painting. label: regions (labels.hpp) at any side, e.g.
// the model's; subsidence: λ per pixel at any side (empty: 1 everywhere);
// metres_per_px: of label. variation ≤ 0 gives an empty plan. Pure in its
// arguments: same seed, same plan.
SeededReefDetails plan_reef_details(const cv::Mat1b& label, const cv::Mat1f& subsidence, double metres_per_px,
                                    uint64_t seed, double variation);

// Paints the plan's motu on the reef cells of `label` (any side) as beach, so
// the painted reef's finish raises them as it raises painted motu.
void paint_seeded_motu(cv::Mat1b& label, const SeededReefDetails& d, double metres_per_px);

// Cuts the plan's passes into h (any side; label at the same side): water
// and reef cells within a pass are lowered to its floor (only lowered; land
// is never touched), its walls wandering by ±35 % of its half-width and
// eased over the outer half of it, the floor varying by ±15 % with a
// seeded noise so it is no flat slab or straight-sided slot.
void cut_seeded_passes(cv::Mat1f& h, const cv::Mat1b& label, const SeededReefDetails& d, double metres_per_px,
                       uint64_t seed);

}  // namespace reefgen::infer
