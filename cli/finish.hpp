#pragma once
// The finishing flags of generate, infer and erode, registered once with one
// meaning (docs/LAYERS.md, docs/GIS.md, docs/ENGINES.md): --layers,
// --layer-rules, --geotiff, --crs, --origin, --for and --ocean-floor-m.
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "reefgen/engines/bundle.hpp"
#include "reefgen/gis/geotiff.hpp"
#include "reefgen/terrain/layers.hpp"

namespace reefgen {

struct FinishFlags {
  bool layers = false;                // the layer files beside the heights
  std::string layer_rules;            // FILE: JSON of terrain::LayerParams
  bool geotiff = false;               // PREFIX.height.tif (+ the float layers with --layers)
  std::string crs, origin;            // of the GeoTIFFs and the gis bundle
  std::vector<std::string> engines;   // --for: bundles, PREFIX.<engine>/
  double ocean_floor_m = 0;           // m, --ocean-floor-m: the open ocean's flank continued towards it; 0 = off

  // What the flags ask for, checked (one line naming the flag otherwise).
  struct Parsed {
    terrain::LayerParams rules;
    gis::GeoReference geo;
    std::vector<engines::Engine> bundles;
    bool need_layers = false;  // the layer files, or a bundle that carries them
  };
  Parsed parse() const;
};

// One stderr line per bundle that resamples a field of `side` samples (the
// README in the bundle says it too); nothing when quiet.
// `fix` as engines::size_note's: "" for erode, which takes its input's size.
void note_bundle_sizes(const FinishFlags::Parsed& fin, int side, bool quiet, const std::string& fix = "--size");

void add_finish_flags(CLI::App* sub, FinishFlags& f);

}  // namespace reefgen
