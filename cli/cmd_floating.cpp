// reefgen floating: a closed floating-island mesh from a painting or a height field.
#include <cstdio>

#include "app.hpp"
#include "reefgen/presets.hpp"
#include "reefgen/files.hpp"
#include "reefgen/islands/floating.hpp"

namespace reefgen {

namespace {
// The params of a built-in preset, or of a config file, or the defaults.
islands::FloatingParams floating_params(const std::string& preset, const std::string& config) {
  if (!preset.empty()) {
    const std::string& text = preset_text(builtin_floating_presets(), preset, "floating preset");
    return islands::floating_params_from_json(nlohmann::json::parse(text), "preset " + preset);
  }
  if (!config.empty()) return islands::floating_params_from_json(read_json(config), config);
  return {};
}
}  // namespace

Command add_floating_command(CLI::App& app, const GlobalOptions& g) {
  auto* sub = app.add_subcommand(
      "floating",
      "Floating island (IslandPaint) as a closed mesh, from a painting or a height field\n\n"
      "The painting is a top view: the top in a top colour (green, white snow), optionally the rock\n"
      "painted in brown below it (how far it reaches sets the depth), on a sky-blue, black or\n"
      "transparent background. With --height, the field's land (h > 0) becomes the top.\n\n"
      "Examples:\n"
      "  reefgen floating --painting docs/examples/floating-painting.png -o out/floating.glb --preview out/floating.png\n"
      "  reefgen floating --painting p.png --preset spire -o spire.obj -o spire.glb\n"
      "  reefgen floating --height out/atoll.height.exr -o atoll-floating.glb     # preset terrain-top\n"
      "  reefgen floating --painting p.png --height out/m4.height.exr -o f.glb    # painted outline, terrain features\n"
      "  reefgen floating --presets                                               # list the presets\n");
  struct Args {
    std::string painting, height, preset, config, preview;
    std::vector<std::string> out;
    uint64_t seed = 1;
    double metres_per_px = 0, depth_stretch = 0, simplify_px = -1;
    int max_size = 0;
    bool list = false;
  };
  auto a = std::make_shared<Args>();
  sub->add_option("--painting", a->painting, "Painting (PNG/JPEG/…, 8 or 16 bit, alpha = background)");
  sub->add_option("--height", a->height, "Height field EXR (metres): its land is the top, or the features under a painting");
  sub->add_option("-o,--output,--out", a->out, "Mesh file(s): .glb or .obj (repeat for both); a .json sidecar is written beside the first");
  sub->add_option("--preset", a->preset, "Built-in params (configs/floating/): default, spire, mesa, terrain-top");
  sub->add_option("--config", a->config, "Params JSON (configs/floating/*.json are examples)");
  sub->add_option("--seed", a->seed, "Seed of the noise features")->capture_default_str()->check(seed_value());
  sub->add_option("--metres-per-px", a->metres_per_px, "Ground size of a pixel (overrides the params / the EXR's own)");
  sub->add_option("--depth-stretch", a->depth_stretch, "Multiplies the bottom (overrides the params)");
  sub->add_option("--simplify", a->simplify_px, "Silhouette polygon tolerance, px (overrides the params)");
  sub->add_option("--max-size", a->max_size,
                  "Mesh at most this many pixels on the long side (the painting is shrunk, its ground size kept; "
                  "a 2048² painting makes ~4 M triangles); 0 = as painted")->capture_default_str();
  sub->add_option("--preview", a->preview,
                  "Also a shaded oblique view: PNG path, or no value for NAME.preview.png beside the first mesh "
                  "(as infer/generate --preview)")
      ->expected(0, 1);
  sub->add_flag("--presets", a->list, "List the built-in presets and exit");
  return {sub, [a, sub, &g]() -> int {
            // --preview alone: beside the first mesh, as the other commands' --preview.
            if (sub->count("--preview") && a->preview.empty() && !a->out.empty())
              a->preview = fs::path(a->out.front()).replace_extension(".preview.png").string();
            const auto& presets = builtin_floating_presets();
            if (a->list) {
              for (const auto& [name, text] : presets) std::printf("%s\n", name.c_str());
              return 0;
            }
            if (!a->preset.empty() && !a->config.empty()) throw Error("floating: use --preset or --config, not both");
            // Params: a preset, a file, or defaults (terrain-top for a height field alone).
            std::string preset = a->preset;
            if (preset.empty() && a->config.empty() && a->painting.empty()) preset = "terrain-top";
            islands::FloatingParams p = floating_params(preset, a->config);
            if (sub->count("--depth-stretch")) p.depth_stretch = a->depth_stretch;
            if (sub->count("--simplify")) p.simplify_px = a->simplify_px;
            islands::FloatingJob job;
            job.painting = a->painting;
            job.height_exr = a->height;
            job.seed = a->seed;
            job.max_size_px = a->max_size;
            if (sub->count("--metres-per-px")) job.metres_per_px = a->metres_per_px;
            job.meshes = a->out;
            job.preview_png = a->preview;
            job.preset = preset;
            job.config = a->config;
            const nlohmann::json side = islands::make_floating(job, p);
            std::printf("%s\n", side.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
            if (!g.quiet)
              std::fprintf(stderr, "floating: %d shell(s), %d triangles, top %.1f m, depth %.1f m, silhouette IoU %.3f\n",
                           side["mesh"]["shells"].get<int>(), side["mesh"]["triangles"].get<int>(),
                           side["top_max_m"].get<double>(), side["depth_m"].get<double>(),
                           side["silhouette_iou"].get<double>());
            return 0;
          }};
}

}  // namespace reefgen
