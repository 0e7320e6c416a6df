#pragma once
// The training-set recipe (paper §5, docs/DESIGN.md §4): which pair index is which
// configuration, subsidence level, split and augmentation. Pure and
// deterministic in (seed, index): a pair can be rebuilt anywhere, which is what
// makes resuming, sharding and verification simple.
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "reefgen/augment/augment.hpp"
#include "reefgen/terrain/erosion.hpp"

namespace reefgen::augment {

struct DatasetParams {
  int64_t count = 10000;       // pairs, [1, 1e8]
  int size_px = 256;           // W, [16, 4096]
  int levels = 4;              // subsidence levels per configuration, [1, 64]
  double val_fraction = 0.05;  // of configurations, [0, 0.5]
  double test_fraction = 0.05; // of configurations, [0, 0.5]
  double p_affine = 0.5;       // probability of rotation/scale/flip, [0, 1]
  double scale_min = 0.6, scale_max = 1.1;  // affine scale range, (0, 4]
  double p_translate = 0.3;    // probability of a wrap-around translation, [0, 1]
  double p_paste = 0.2;        // probability of copy-paste of 2-3 islands, [0, 1]
  double paste_scale = 0.5;    // scale of pasted islands, (0, 1]
  double max_iou = 0.10;       // footprint IoU bound for copy-paste, [0, 1]
  double p_mapgen4 = 0;        // probability a pair is a mapgen4-style island cut into height bands, [0, 1]
  double p_wilbur = 0;         // same for Wilbur-style islands; p_mapgen4 + p_wilbur ≤ 1
  // Subsidence: `levels` evenly spaced values per configuration (the paper's
  // ladder), or with continuous_subsidence each pair draws λ ~ U[min, max]
  // (the authors' code draws 1 − λ in [0.1, 1]): any painted brightness is
  // then inside the training distribution.
  bool continuous_subsidence = false;
  double subsidence_min = 0;   // [0, 1]
  double subsidence_max = 1;   // [subsidence_min, 1]
  // Whole islands: a wrap-around translation (of the sample or of a pasted
  // island) only happens when the footprint leaves a border ring of
  // `border_px` pixels all abyss; otherwise an island cut by the canvas edge
  // would come back as an island cut by a straight line inside the canvas.
  bool whole_islands = true;
  int border_px = 2;           // [1, 64]
  double p_erosion = 0;        // probability a curve island is eroded (terrain/erosion.hpp), [0, 1]
  terrain::ErosionParams erosion;  // JSON: optional object "erosion"
  // Island ages (reefgen/age.hpp), so a model can be conditioned on them:
  // with age_min_myr ≥ 0 each curve pair draws an age log-uniform in
  // [age_min_myr, age_max_myr] that sets its subsidence and its erosion
  // maturity (over the subsidence draws); else, with maturity_min <
  // maturity_max, a maturity log-uniform in that range alone. The defaults
  // draw neither: the pairs of earlier datasets, byte for byte.
  double age_min_myr = -1;     // My, [-1, 60]; -1 = no age drawn
  double age_max_myr = -1;     // My, [age_min_myr, 60]
  double maturity_min = 1;     // [0.05, 20]
  double maturity_max = 1;     // [maturity_min, 20]
  // Redraw the sea floor of every curve pair after its augmentation
  // (redraw_flank): its descent then follows the augmented canvas, not the
  // generator's (whose scale the affine step changed). Off: earlier datasets.
  bool redraw_flank = false;
};

// The one field list (common/params_json.hpp); dataset_params_from_json adds
// the rules between fields (scale_min ≤ scale_max, subsidence_min ≤
// subsidence_max, p_mapgen4 + p_wilbur ≤ 1).
template <class F>
void fields(DatasetParams& p, F&& f) {
  f("count", p.count, Range{1, 1e8});
  f("size_px", p.size_px, Range{16, 4096});
  f("levels", p.levels, Range{1, 64});
  f("val_fraction", p.val_fraction, Range{0, 0.5});
  f("test_fraction", p.test_fraction, Range{0, 0.5});
  f("p_affine", p.p_affine, Range{0, 1});
  f("scale_min", p.scale_min, Range{1e-3, 4});
  f("scale_max", p.scale_max, Range{1e-3, 4});
  f("p_translate", p.p_translate, Range{0, 1});
  f("p_paste", p.p_paste, Range{0, 1});
  f("paste_scale", p.paste_scale, Range{1e-3, 1});
  f("max_iou", p.max_iou, Range{0, 1});
  f("p_mapgen4", p.p_mapgen4, Range{0, 1});
  f("p_wilbur", p.p_wilbur, Range{0, 1});
  f("continuous_subsidence", p.continuous_subsidence);
  f("subsidence_min", p.subsidence_min, Range{0, 1});
  f("subsidence_max", p.subsidence_max, Range{0, 1});
  f("whole_islands", p.whole_islands);
  f("border_px", p.border_px, Range{1, 64});
  f("p_erosion", p.p_erosion, Range{0, 1});
  f("erosion", p.erosion);
  f("age_min_myr", p.age_min_myr, Range{-1, 60});
  f("age_max_myr", p.age_max_myr, Range{-1, 60});
  f("maturity_min", p.maturity_min, Range{0.05, 20});
  f("maturity_max", p.maturity_max, Range{0.05, 20});
  f("redraw_flank", p.redraw_flank);
}
void to_json(nlohmann::json& j, const DatasetParams& p);
// Every key optional; unknown keys and out-of-range values throw Error naming them.
DatasetParams dataset_params_from_json(const nlohmann::json& j, const std::string& origin);

enum class Split { kTrain, kVal, kTest };
const char* split_name(Split s);
// Split of configuration c: whole configurations go to one split, so no island
// appears (at another subsidence or augmentation) in two splits.
Split split_of(uint64_t seed, int64_t configuration, const DatasetParams& p);

struct PairInfo {
  int64_t index, configuration;
  int level;
  double subsidence;
  Split split;
  uint64_t seed = 0;         // the island's generator seed (its spec's noise.seed)
  double age_myr = -1;       // the age drawn (DatasetParams::age_min_myr), -1 = none
  double maturity = 1;       // erosion maturity (terrain::matured; 1 = the dataset's erosion as given)
  double ruggedness = 1;     // per-region style (DecodedSketch::ruggedness / 255): the generator's islands are rugged
  nlohmann::json augmentation;  // what was applied, for the manifest
};

PairInfo pair_info(uint64_t seed, int64_t index, const DatasetParams& p);
// Generates and augments pair `index`.
Pair make_pair(uint64_t seed, int64_t index, const DatasetParams& p, PairInfo* info = nullptr);

// True when the ring of `border_px` pixels along the canvas edge is all abyss:
// the island is whole inside the canvas and may wrap-translate.
bool border_is_abyss(const cv::Mat1b& label, int border_px);

}  // namespace reefgen::augment
