// reefgen sketch: label sketches from thresholded noise (paper Fig. 17), the
// other island systems or a height field, to try `reefgen infer` without drawing.
#include <cstdio>

#include "app.hpp"
#include "reefgen/io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/procgen/sketch.hpp"
#include "reefgen/islands/terrains.hpp"

namespace reefgen {

namespace {
// Sketches are PNG (lossless, the palette survives): a name with another
// extension would hold PNG bytes under a misleading name.
void require_png_name(const fs::path& p) {
  std::string e = p.extension().string();
  for (auto& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (e != ".png")
    throw Error(p.string() + ": sketches are written as PNG; name the output *.png");
}

struct RandomArgs {
  procgen::SketchParams p;
  procgen::ArchipelagoParams world;
  std::string size = "256";
  uint64_t seed = 1;
  int count = 1;
  std::string out;
};

// --size W (one canvas: the paper's sketches) or WxH (an archipelago);
// returns whether it is an archipelago and fills the sizes.
bool parse_sketch_size(RandomArgs& a, bool islands_given) {
  int w = 0, h = 0;
  char x = 0, rest = 0;
  const int n = std::sscanf(a.size.c_str(), "%d%c%d%c", &w, &x, &h, &rest);
  if (n == 1) {
    a.p.size_px = w;
    return false;
  }
  if (n != 3 || (x != 'x' && x != 'X'))
    throw Error("--size " + a.size + ": use W (one 6 km canvas) or WxH (an archipelago), e.g. 2048x2048");
  a.world.width_px = w;
  a.world.height_px = h;
  a.world.islands = islands_given ? a.p.islands : procgen::ArchipelagoParams{}.islands;
  return true;
}

struct FromArgs {
  std::string from, out, config;
  uint64_t seed = 1;
  int size = 256;
  double subsidence = 0.0;
  islands::SketchBands bands;
};

// `sketch --from KIND|H.exr -o FILE`: a terrain or height field cut into the five regions.
int run_sketch_from(const FromArgs& f, bool size_given) {
  procgen::Sketch s;
  const bool terrain = f.from == "mapgen4" || f.from == "wilbur";
  if (!f.config.empty() && !terrain)
    throw Error("--config " + f.config + ": applies to --from mapgen4 or wilbur only");
  if (terrain && !f.config.empty()) {
    s = islands::height_to_sketch(islands::configured_terrain(f.from, read_json(f.config), f.config,
                                                              size_given ? f.size : 0, f.seed),
                                  f.subsidence, f.bands);
  } else if (terrain) {
    s = islands::height_to_sketch(islands::named_terrain(f.from, f.size, f.seed), f.subsidence, f.bands);
  } else if (f.from == "noise") {
    procgen::SketchParams sp;
    sp.size_px = f.size;
    sp.subsidence = f.subsidence;
    s = procgen::random_sketch(sp, f.seed);
  } else {
    const fs::path exr(f.from);
    if (exr.extension() != ".exr")
      throw Error("--from " + f.from + ": use mapgen4, wilbur, noise, or a height field .exr");
    refuse_output_over_input({exr}, {fs::path(f.out)});
    const cv::Mat1f h = read_exr_height(exr);
    if (cv::checkRange(h, true) == false)
      throw Error(exr.string() + ": the height field holds NaN or infinite values; fix or regenerate it");
    s = islands::height_to_sketch(h, f.subsidence, f.bands);
  }
  const fs::path path(f.out);
  require_png_name(path);
  if (path.has_parent_path()) ensure_writable_dir(path.parent_path());
  write_png(path, encode_labels(s.label, s.subsidence));
  std::printf("%s\n", path.c_str());
  return 0;
}

// `sketch random`: noise sketches on one 6 km canvas, or an archipelago (--size WxH).
int run_sketch_random(RandomArgs& a, bool islands_given) {
  if (a.count < 1) throw Error("--count must be ≥ 1");
  const bool archipelago = parse_sketch_size(a, islands_given);
  auto make = [&](uint64_t seed) {
    return archipelago ? procgen::archipelago_sketch(a.world, seed) : procgen::random_sketch(a.p, seed);
  };
  if (!archipelago) (void)procgen::random_sketch(a.p, a.seed);  // validate before writing
  const bool many = a.count > 1;
  if (!many) require_png_name(a.out);
  if (many) ensure_writable_dir(a.out);
  StagedOutputs staged;  // all or nothing: a failure keeps an earlier set as it was
  for (int i = 0; i < a.count; ++i) {
    const procgen::Sketch s = make(a.seed + uint64_t(i));
    char name[32];
    std::snprintf(name, sizeof name, "sketch_%04d.png", i);
    const fs::path path = many ? fs::path(a.out) / name : fs::path(a.out);
    if (!many && path.has_parent_path()) ensure_writable_dir(path.parent_path());
    staged.write(path, [&](const fs::path& t) { write_png(t, encode_labels(s.label, s.subsidence)); });
  }
  staged.commit();
  for (const auto& path : staged.finals()) std::printf("%s\n", path.c_str());
  return 0;
}

}  // namespace

Command add_sketch_command(CLI::App& app, const GlobalOptions&) {
  auto* sub = app.add_subcommand(
      "sketch",
      "Make label sketches to try `reefgen infer` without drawing\n\n"
      "Examples:\n"
      "  reefgen sketch random --seed 3 -o sketch.png          # thresholded noise (Figure 17)\n"
      "  reefgen sketch --from wilbur --seed 2 -o wilbur.png    # a Wilbur-style island, cut into height bands\n"
      "  reefgen sketch --from mapgen4 --seed 2 -o m4.png       # a mapgen4-style island\n"
      "  reefgen sketch --from wilbur --config configs/terrains/wilbur-highlands.json -o hl.png\n"
      "  reefgen sketch --from out/atoll.height.exr -o atoll.png --subsidence 0.6\n");
  auto f = std::make_shared<FromArgs>();
  sub->add_option("--from", f->from, "mapgen4, wilbur, noise, or a height EXR (metres): its land/water and depth/elevation bands become the five regions");
  sub->add_option("-o,--output,--out", f->out, "PNG file (with --from)");
  sub->add_option("--config", f->config, "Terrain params JSON for --from mapgen4|wilbur (configs/terrains/KIND*.json)");
  sub->add_option("--seed", f->seed, "Seed (wilbur, noise)")->capture_default_str()->check(seed_value());
  sub->add_option("--size", f->size, "W (wilbur, noise)")->capture_default_str();
  sub->add_option("--subsidence", f->subsidence, "λ in [0, 1] written in the value channel")->capture_default_str()->check(finite_in(0, 1));
  sub->add_option("--beach-top", f->bands.beach_top_m, "Land below this (m) is beach")->capture_default_str();
  sub->add_option("--lagoon-depth", f->bands.lagoon_depth_m, "Water shallower than this (m) is lagoon")->capture_default_str();
  sub->add_option("--reef-depth", f->bands.reef_depth_m, "Then reef down to this depth (m); deeper is abyss")->capture_default_str();
  auto* rnd = sub->add_subcommand(
      "random",
      "Sketch from thresholded noise (the paper's Figure 17)\n\n"
      "Examples:\n"
      "  reefgen sketch random --seed 3 -o sketch.png\n"
      "  reefgen sketch random --seed 4 --islands 3 --subsidence 0.8 -o atolls.png\n"
      "  reefgen sketch random --seed 5 --count 20 -o sketches/     # sketches/sketch_0000.png ...\n"
      "  reefgen sketch random --size 2048x2048 --islands 24 -o sea.png   # an archipelago, 48 km across\n\n"
      "--size W draws one canvas of 6 km whatever W (the paper's sketches); --size WxH draws\n"
      "an archipelago at the model's own scale (--metres-per-px, 23.4 m: 2048 px = 48 km) with\n"
      "young high islands, barrier reefs and atolls of very different sizes, some crossing\n"
      "the border, for `reefgen world`.\n");
  sub->require_subcommand(0, 1);
  auto a = std::make_shared<RandomArgs>();
  rnd->add_option("--seed", a->seed, "Seed")->capture_default_str()->check(seed_value());
  rnd->add_option("-o,--output,--out", a->out, "PNG file, or a folder with --count > 1")->required();
  rnd->add_option("--count", a->count, "Number of sketches (seeds seed, seed+1, ...)")->capture_default_str();
  rnd->add_option("--size", a->size, "W (one 6 km canvas) or WxH (an archipelago at --metres-per-px)")->capture_default_str();
  rnd->add_option("--islands", a->p.islands, "Islands per sketch [1, 16]; archipelago [1, 512] (default 24)");
  rnd->add_option("--metres-per-px", a->world.metres_per_px, "Archipelago: ground of one pixel, m")
      ->capture_default_str()->check(finite_in(1e-3, 1000));
  rnd->add_option("--subsidence", a->p.subsidence, "λ in [0, 1] (darker colours); -1 = random per island")->capture_default_str()->check(finite_in(-1, 1));
  rnd->add_option("--roughness", a->p.roughness, "Outline noise amplitude [0, 1]")->capture_default_str();
  return {sub, [a, f, rnd, sub]() -> int {
    if (rnd->parsed()) return run_sketch_random(*a, rnd->count("--islands") > 0);
    if (f->from.empty() || f->out.empty())
      throw Error("sketch: use `reefgen sketch random -o FILE` or `reefgen sketch --from mapgen4|wilbur|noise|H.exr -o FILE`");
    return run_sketch_from(*f, sub->count("--size") > 0);
  }};
}

}  // namespace reefgen
