// reefgen terrain: height fields from the other island systems (islands/:
// mapgen4-style, Wilbur-style) on reefgen's conventions. Thin: flags ->
// islands library -> files.
#include <cstdio>

#include "app.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/heightfile.hpp"
#include "reefgen/files.hpp"
#include "reefgen/islands/terrains.hpp"

namespace reefgen {

Command add_terrain_command(CLI::App& app, const GlobalOptions&) {
  auto* sub = app.add_subcommand(
      "terrain",
      "Height fields from the other island systems (mapgen4-style, Wilbur-style), on reefgen's conventions\n\n"
      "Examples:\n"
      "  reefgen terrain mapgen4 --seed 2 -o out/m4 --preview\n"
      "  reefgen terrain wilbur --seed 5 --size 512 -o out/w5\n"
      "  reefgen terrain wilbur --config configs/terrains/wilbur.json --seed 5 -o out/w5\n"
      "  reefgen terrain mapgen4 --config configs/terrains/mapgen4-round.json -o out/m4r --mesh glb\n");
  struct Args {
    std::string kind, out, config;
    uint64_t seed = 1;
    int size = 256;
    bool preview = false;
    std::string mesh;
  };
  auto a = std::make_shared<Args>();
  sub->add_option("kind", a->kind, "mapgen4 or wilbur")->required();
  sub->add_option("--mesh", a->mesh, "Also a grid mesh: glb or obj (PREFIX.glb / PREFIX.obj; metres, +Y up)")
      ->check(CLI::IsMember({"glb", "obj"}));
  sub->add_option("--config", a->config, "Params JSON (configs/terrains/KIND.json is the defaults serialised)");
  sub->add_option("-o,--output,--out", a->out, "Output prefix: PREFIX.height.exr (+ PREFIX.preview.png)")->required();
  sub->add_option("--seed", a->seed, "Seed")->capture_default_str()->check(seed_value());
  sub->add_option("--size", a->size, "W")->capture_default_str();
  sub->add_flag("--preview", a->preview, "Also the coloured, hill-shaded preview");
  return {sub, [a, sub]() -> int {
            const cv::Mat1f h = a->config.empty() ? islands::named_terrain(a->kind, a->size, a->seed)
                                                  : islands::configured_terrain(a->kind, read_json(a->config), a->config,
                                                                                sub->count("--size") ? a->size : 0, a->seed);
            const fs::path prefix = output_names(a->out).prefix;  // refuses "-o dir/" (hidden .height.exr)
            if (prefix.has_parent_path()) ensure_writable_dir(prefix.parent_path());
            StagedOutputs staged;  // all or nothing: a failure keeps an earlier result as it was
            HeightFiles hf;
            hf.preview = a->preview;
            hf.mesh = a->mesh;
            // reefgen's canvas convention (docs/DESIGN.md §2: 6 km across), so that
            // `reefgen floating --height` and previews know the scale.
            hf.exr_attributes = {{"reefgen:generator", a->kind}, {"reefgen:seed", std::to_string(a->seed)}};
            stage_height_files(staged, prefix, h, kCanvasWorldSizeM / h.cols, hf);
            staged.commit();
            std::printf("%s.height.exr\n", prefix.c_str());
            return 0;
          }};
}

}  // namespace reefgen
