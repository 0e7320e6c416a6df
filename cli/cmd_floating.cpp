// reefgen floating: a closed floating-island mesh from a painting or a height field.
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "app.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/io.hpp"
#include "reefgen/mesh.hpp"
#include "reefgen/islands/floating.hpp"
#include "reefgen/version.hpp"

namespace reefgen {

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
            if (a->painting.empty() && a->height.empty())
              throw Error("floating: give --painting FILE or --height H.exr (see reefgen floating --help)");
            if (a->out.empty()) throw Error("floating: give -o FILE.glb or -o FILE.obj");
            for (const auto& o : a->out) {
              const std::string ext = fs::path(o).extension().string();
              if (ext != ".glb" && ext != ".obj") throw Error("-o " + o + ": the mesh file must end in .glb or .obj");
            }
            {  // no output may be an input (the painting, the height field, the config)
              std::vector<fs::path> ins, outs(a->out.begin(), a->out.end());
              for (const auto& i : {a->painting, a->height, a->config})
                if (!i.empty()) ins.push_back(i);
              if (!a->preview.empty()) outs.push_back(a->preview);
              outs.push_back(fs::path(a->out.front()).replace_extension(".json"));
              refuse_output_over_input(ins, outs);
              for (size_t i = 0; i < outs.size(); ++i)
                for (size_t k = i + 1; k < outs.size(); ++k)
                  if (fs::path(outs[i]).lexically_normal() == fs::path(outs[k]).lexically_normal())
                    throw Error(outs[i].string() + ": named twice as an output; give each output its own name");
            }
            if (!a->preset.empty() && !a->config.empty()) throw Error("floating: use --preset or --config, not both");
            // Params: a preset, a file, or defaults (terrain-top for a height field alone).
            std::string preset = a->preset;
            if (preset.empty() && a->config.empty() && a->painting.empty()) preset = "terrain-top";
            islands::FloatingParams p;
            if (!preset.empty()) {
              const auto it = presets.find(preset);
              if (it == presets.end()) {
                std::string names;
                for (const auto& [n, t] : presets) names += (names.empty() ? "" : ", ") + n;
                throw Error("--preset " + preset + ": unknown; use one of " + names);
              }
              p = islands::floating_params_from_json(nlohmann::json::parse(it->second), "preset " + preset);
            } else if (!a->config.empty()) {
              p = islands::floating_params_from_json(read_json(a->config), a->config);
            }
            if (sub->count("--depth-stretch")) p.depth_stretch = a->depth_stretch;
            if (sub->count("--simplify")) p.simplify_px = a->simplify_px;

            // The top silhouette and the features H₀.
            cv::Mat1b labels;
            cv::Mat3f top_rgb;  // painted top colours (snow stays white on the mesh)
            cv::Mat1f h0;
            cv::Mat1f terrain;
            if (!a->height.empty()) {
              ExrAttributes attrs;
              terrain = read_exr_height(a->height, &attrs);
              if (a->painting.empty()) {  // the terrain is the canvas: its pixel size, or reefgen's 6 km across
                const double mpp = exr_metres_per_px(attrs);  // else reefgen's 6 km canvas
                p.metres_per_px = mpp > 0 ? mpp : kCanvasWorldSizeM / terrain.cols;
              }
              islands::check_floating_heights(terrain, a->height);
            }
            if (sub->count("--metres-per-px")) p.metres_per_px = a->metres_per_px;
            islands::validate(p);
            if (!a->painting.empty()) {
              if (!fs::is_regular_file(a->painting)) throw Error(a->painting + ": no such file (check the path)");
              const cv::Mat img = islands::shrink_painting(read_image(a->painting, cv::IMREAD_UNCHANGED), a->max_size, p);
              labels = islands::segment_painting(img, p, a->painting, &top_rgb);
              if (terrain.empty()) {
                h0 = islands::floating_features(labels.size(), p, a->seed);
              } else {  // the terrain's land relief under the painted outline
                cv::resize(cv::max(terrain, 0.f), h0, labels.size(), 0, 0, cv::INTER_LINEAR);
              }
            } else {
              islands::HeightTop top = islands::top_of_height_field(terrain, a->height);
              labels = top.labels;
              h0 = top.h0_m;
            }
            const std::string source = a->painting.empty() ? a->height : a->painting;
            islands::FloatingIsland isl;
            try {
              isl = islands::floating_island(labels, h0, p, top_rgb);
            } catch (const Error& e) {
              throw Error(source + ": " + e.what());
            }
            // Check what we are about to hand to Blender: refuse rather than write a broken mesh.
            const MeshReport rep = inspect_mesh(isl.mesh);
            if (!rep.closed_manifold())
              throw Error(source + ": internal error: the mesh is not closed (" + std::to_string(rep.open_edges) +
                          " open edges, " + std::to_string(rep.degenerate) + " degenerate triangles); please report it");
            const double iou = islands::mask_iou(islands::mesh_silhouette(isl.mesh, labels.size(), p.metres_per_px),
                                                 labels == islands::kPaintTop);

            // Staged, renamed into place together: a failure (an output that
            // is a folder, a full disk) leaves earlier files as they were.
            StagedOutputs staged;
            for (const auto& o : a->out) {
              const fs::path path(o);
              ensure_writable_dir(path.has_parent_path() ? path.parent_path() : fs::path("."));
              staged.write(path, [&](const fs::path& t) {
                if (path.extension() == ".obj")
                  write_obj(t, isl.mesh, "reefgen floating island: metres, +Y up, closed 2-manifold");
                else
                  write_glb(t, isl.mesh, "floating-island");
              });
            }
            if (!a->preview.empty()) {
              const fs::path path(a->preview);
              ensure_writable_dir(path.has_parent_path() ? path.parent_path() : fs::path("."));
              staged.write(path, [&](const fs::path& t) { write_png(t, islands::render_mesh(isl.mesh, 768)); });
            }
            const nlohmann::json side = {
                {"reefgen_version", kVersion},
                {"source", fs::absolute(source).string()},
                {"features", terrain.empty() ? "noise" : fs::absolute(a->height).string()},
                {"seed", a->seed},
                {"preset", preset},
                {"params", islands::to_json(p)},
                {"mesh", {{"files", a->out}, {"units", "metres"}, {"up", "+Y"},
                          {"vertices", isl.mesh.positions.size()}, {"triangles", isl.mesh.triangles.size()},
                          {"shells", isl.islands}, {"closed_2_manifold", true}, {"volume_m3", rep.volume_m3}}},
                {"top_max_m", isl.top_max_m},
                {"depth_m", isl.depth_m},
                {"silhouette_iou", iou}};
            const fs::path js = fs::path(a->out.front()).replace_extension(".json");
            staged.write(js, [&](const fs::path& t) { write_json_atomic(t, side); });  // last
            staged.commit();
            std::printf("%s\n", side.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
            if (!g.quiet)
              std::fprintf(stderr, "floating: %d shell(s), %zu triangles, top %.1f m, depth %.1f m, silhouette IoU %.3f\n",
                           isl.islands, isl.mesh.triangles.size(), isl.top_max_m, isl.depth_m, iou);
            return 0;
          }};
}

}  // namespace reefgen
