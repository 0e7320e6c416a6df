// reefgen: coral-reef island terrains from curves or painted sketches.
// Thin main: parse, dispatch, turn every exception into one line + exit 1.
#include <cstdio>
#include <exception>

#include "app.hpp"
#include "reefgen/version.hpp"

int main(int argc, char** argv) {
  CLI::App app{"reefgen " + std::string(reefgen::kVersion) +
               " - procedural and learning-based coral reef island terrains\n\n"
               "Examples:\n"
               "  reefgen generate --preset atoll -o out/atoll --preview\n"
               "  reefgen generate --spec my_island.json -o out/mine --size 512\n"
               "  reefgen generate --random 100 --seed 7 --out out/random --threads 2\n"
               "  reefgen presets\n"
               "  reefgen dataset build --config configs/dataset/paper.json --out data/paper\n"
               "  reefgen train --data data/paper --out runs/paper\n"
               "  reefgen sketch random --seed 3 -o sketch.png\n"
               "  reefgen terrain mapgen4 --seed 2 -o out/m4 --preview\n"
               "  reefgen floating --painting docs/examples/floating-painting.png -o out/floating.glb --preview out/floating.png\n"
               "  reefgen infer sketch.png -m runs/paper/generator.pt -o out/island --preview --r16\n"
               "  reefgen eval -m runs/paper/generator.pt --data data/paper --split test\n"
               "  reefgen bench generate\n"};
  app.set_version_flag("--version", std::string("reefgen ") + reefgen::kVersion);
  app.require_subcommand(1);
  reefgen::GlobalOptions g;
  app.add_flag("-q,--quiet", g.quiet, "No progress or log lines on stderr");
  const std::vector<reefgen::Command> commands = {reefgen::add_generate_command(app, g),
                                                  reefgen::add_presets_command(app, g),
                                                  reefgen::add_dataset_command(app, g),
                                                  reefgen::add_train_command(app, g),
                                                  reefgen::add_infer_command(app, g),
                                                  reefgen::add_sketch_command(app, g),
                                                  reefgen::add_terrain_command(app, g),
                                                  reefgen::add_floating_command(app, g),
                                                  reefgen::add_eval_command(app, g),
                                                  reefgen::add_eval_sketches_command(app, g),
                                                  reefgen::add_model_command(app, g),
                                                  reefgen::add_bench_command(app, g)};
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    for (const auto& c : commands)
      if (c.sub->parsed()) return c.run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "reefgen: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
