#pragma once
// One `reefgen world` run (docs/WORLDS.md): a sketch of a whole sea read at
// the model's own scale into one drained height field, its layers and engine
// bundles (tiled past kMaxWholeAmplifySidePx). The CLI parses flags and loads
// the generator; this checks the outputs, keeps finished work in
// PREFIX.partial/ for the same command to resume, and writes all or nothing.
#include <cstdint>
#include <string>
#include <vector>

#include "reefgen/age.hpp"
#include "reefgen/engines/bundle.hpp"
#include "reefgen/files.hpp"
#include "reefgen/gis/geotiff.hpp"
#include "reefgen/heightfile.hpp"
#include "reefgen/infer/infer.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/terrain/layers.hpp"

namespace reefgen::infer {

struct WorldJob {
  fs::path sketch;
  fs::path prefix;                // PREFIX.height.exr, PREFIX.json, ...
  std::string model_path;         // the generator's file: recorded, and part of the resume key
  double sketch_metres_per_px = kModelMetresPerPx;  // ground of one sketch pixel, m
  int size = 0;                   // output side along the longer axis (0: the model's answer's), px
  bool raw = false;               // the network's bare answer at the model's scale
  HeightFiles files;              // png16 / r16 / preview
  InferOptions options;           // precision, engine, seed and variation (the re-roll), the amplification, the age and maturity (applied by run_world as by infer)
  // Finishing: the layer files, GeoTIFFs, bundles and the deeper flank.
  bool layers = false;            // the layer files (tiled past one file)
  bool need_layers = false;       // layers, or a bundle that carries them
  terrain::LayerParams layer_rules;
  bool geotiff = false;
  gis::GeoReference geo;
  std::vector<engines::Engine> bundles;
  double ocean_floor_m = 0;       // < 0: the open ocean's flank continued towards it
  // The flags as given (files asked for, CRS, origin, bundles): a checkpoint
  // is resumed only by the same command (with the same layer rules).
  nlohmann::json flags_key;
  int threads = 1;
  bool quiet = false;
};

// Refused before any work (a command calls them before it loads the
// generator): an output file or bundle folder that is the sketch; a bundle a
// world of this shape (`square`) or side cannot take.
void refuse_world_over_sketch(const WorldJob& job);
void check_world_finish(const WorldJob& job, bool square);

// The world of `sketch` (read from job.sketch, its age applied): its fields
// from the checkpoint where an earlier run of the same command made them,
// every file staged and moved into place together, the checkpoint removed.
// Two runs with one prefix are refused (a lock). Prints each final file's
// path on stdout, as `generate` does; progress on stderr unless quiet.
void run_world(model::GeneratorFile& gen, const DecodedSketch& sketch, const WorldJob& job);

}  // namespace reefgen::infer
