#include "finish.hpp"

#include "app.hpp"

#include <cstdio>

#include "reefgen/error.hpp"
#include "reefgen/files.hpp"
#include "reefgen/terrain/ocean_floor.hpp"

namespace reefgen {

FinishFlags::Parsed FinishFlags::parse() const {
  Parsed p;
  p.bundles = engines::engines_from_strings(engines);
  const bool engine_layers = std::any_of(p.bundles.begin(), p.bundles.end(),
                                         [](engines::Engine e) { return e != engines::Engine::Gis; });
  p.need_layers = layers || engine_layers;
  if (!layer_rules.empty()) {
    if (!p.need_layers) throw Error("--layer-rules " + layer_rules + " needs --layers or --for unity/unreal");
    p.rules = terrain::layer_params_from_json(read_json(layer_rules), layer_rules);
  }
  p.geo.crs = crs;
  if (!origin.empty()) gis::parse_origin(origin, p.geo);
  const bool gis_bundle = std::find(p.bundles.begin(), p.bundles.end(), engines::Engine::Gis) != p.bundles.end();
  if (geotiff || gis_bundle) gis::check_crs(p.geo.crs);
  return p;
}

void note_bundle_sizes(const FinishFlags::Parsed& fin, int side, bool quiet, const std::string& fix) {
  if (quiet) return;
  for (const engines::Engine e : fin.bundles)
    if (const std::string note = engines::size_note(e, side, fix); !note.empty()) std::fprintf(stderr, "note: %s\n", note.c_str());
}

void add_finish_flags(CLI::App* sub, FinishFlags& f) {
  sub->add_flag("--layers", f.layers,
                "Also the layers (docs/LAYERS.md): PREFIX.flow.png, .slope.png, .wear.png, .deposit.png, "
                ".normal.png, .splat0.png + .splat1.png (8 material weights), .materials.png");
  sub->add_option("--layer-rules", f.layer_rules, "JSON of material rules overriding the defaults (docs/LAYERS.md)")
      ->type_name("FILE");
  sub->add_flag("--geotiff", f.geotiff,
                "Also PREFIX.height.tif (float32 metres; with --layers the float layers too) for GIS (docs/GIS.md)");
  sub->add_option("--crs", f.crs, "CRS of the GeoTIFFs, e.g. EPSG:32706 (default: a local metric grid, no CRS)");
  sub->add_option("--origin", f.origin, "X,Y: map coordinates of the top-left corner, metres (default: centred on 0,0)");
  sub->add_option("--for", f.engines,
                  "Bundles in each tool's own layout, each in PREFIX.<engine>/ with a README.txt of import steps: " +
                  engines::engine_names() + " (comma-separated or repeated; docs/ENGINES.md)")
      ->type_name("ENGINE");
  sub->add_option("--ocean-floor-m", f.ocean_floor_m,
                  "Continue the submarine flank towards this depth, e.g. -2000 (metres, [-11000, -60]): the open "
                  "ocean below -60 m sinks with its distance from the reef, leaving it at 35 deg and relaxing "
                  "with depth, so the floor is reached kilometres out; lagoons are kept "
                  "(docs/REEF.md \"Deeper than the abyss\")")
      ->check(finite_in(terrain::kDeepestOceanFloorM, terrain::kShallowestOceanFloorM))
      ->type_name("M");
}

}  // namespace reefgen
