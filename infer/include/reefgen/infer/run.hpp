#pragma once
// One `reefgen infer` run: sketch files in, height files and sidecars out
// (docs/INFERENCE.md). The CLI parses flags and loads the generator; this
// checks every output name, infers in bounded chunks and writes all or nothing.
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "reefgen/engines/bundle.hpp"
#include "reefgen/gis/geotiff.hpp"
#include "reefgen/terrain/layers.hpp"
#include "reefgen/heightfile.hpp"
#include "reefgen/infer/infer.hpp"
#include "reefgen/files.hpp"

namespace reefgen::infer {

// The sketches named by files and folders (a folder's images in name order).
// Throws reefgen::Error for a missing path or a folder without images.
struct SketchInputs {
  std::vector<fs::path> files;
  bool from_folder = false;  // a folder was named: -o is a folder even for one sketch
};
SketchInputs sketch_inputs(const std::vector<std::string>& paths);

struct InferJob {
  SketchInputs inputs;
  std::string out;         // one sketch: PREFIX or NAME.exr; several (or a folder given): a folder
  std::string mesh;        // "", "obj", "glb", or a path ending in .obj/.glb (one sketch only)
  HeightFiles files;       // png16 / r16 / preview / exaggeration (mesh and paths are set here)
  std::string model_path;  // recorded in the sidecars
  InferOptions options;
  bool layers = false;                // also the layer files (docs/LAYERS.md)
  terrain::LayerParams layer_params;  // their rules
  bool geotiff = false;               // also PREFIX.height.tif (+ float layers), docs/GIS.md
  gis::GeoReference geo;
  std::vector<engines::Engine> bundles;  // engine bundles, PREFIX.<engine>/ (docs/ENGINES.md)
  int threads = 1;                    // for the layers and their files
  bool quiet = true;                  // false: a line on stderr per stage of a large island (kStageLinesSidePx)
  // Islands of the one sketch, seeds options.seed … + variations − 1 (1: one
  // island at PREFIX). Past 1 each goes to PREFIX.seedS.* with all its files,
  // and PREFIX.variations.png shows them side by side (docs/INFERENCE.md).
  int variations = 1;
};
// An output this wide or wider takes seconds a stage: its stages are named
// on stderr as they start and end (the amplification, the files).
inline constexpr int kStageLinesSidePx = 2049;
// Most variations of one sketch a run makes.
inline constexpr int kMaxVariations = 16;
struct InferResult {
  std::vector<fs::path> heights;       // the EXR of each sketch (each variation), in input (seed) order
  std::vector<fs::path> files;         // every file written (bundles' included), as `generate` lists them
  std::vector<std::string> r16_notes;  // R16 import notes (with --r16), one per sketch
  // One per sketch much larger than the model's side (kWorldHintSidePx): it
  // was read as one 6 km island; `reefgen world` reads it at the model's scale.
  std::vector<std::string> world_notes;
};
// A sketch wider or taller than this is likely a world, not one island, px.
inline constexpr int kWorldHintSidePx = 2 * kModelSidePx;
// Refuses, before writing anything: an output that is an input, two sketches
// with one result name, a mesh path for several sketches, a model without
// dropout for a stochastic run. Infers 32 sketches at a time (memory bounded
// for any folder) and renames every file into place at the end, so a failure
// anywhere leaves an earlier run's files as they were. `done(k)` is called
// after each sketch.
InferResult infer_files(model::GeneratorFile& gen, const InferJob& job,
                        const std::function<void(size_t)>& done = {});

}  // namespace reefgen::infer
