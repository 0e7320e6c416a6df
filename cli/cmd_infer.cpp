// reefgen infer: painted sketches -> height fields in the formats terrain
// tools import (docs/INFERENCE.md). Thin: inputs -> infer library -> files.
#include <cstdio>
#include <map>
#include <optional>

#include "app.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/heightfile.hpp"
#include "reefgen/infer/infer.hpp"
#include "reefgen/io.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/train/fused_adam.hpp"
#include "reefgen/version.hpp"

namespace reefgen {

namespace {

}  // namespace

Command add_infer_command(CLI::App& app, const GlobalOptions& g) {
  auto* sub = app.add_subcommand(
      "infer",
      "Turn painted label sketches into height fields with a trained generator\n\n"
      "Colours (paper §7): red abyss, blue reef, cyan lagoon, green beach, yellow island (mountain);\n"
      "darker = more subsidence. Any size (resized to the model's side and back), PNG/JPEG,\n"
      "8/16-bit, alpha, anti-aliased brushes.\n\n"
      "Examples:\n"
      "  reefgen infer sketch.png -o out/island --preview                 # the shipped model\n"
      "  reefgen infer sketch.png -m runs/paper/generator.pt -o out/island --preview\n"
      "  reefgen infer sketches/ -m generator.pt -o out/ --png16 --r16\n"
      "  reefgen infer sketch.png -m generator.pt -o out/island --mesh out/island.glb --exaggeration 3\n"
      "  reefgen infer sketch.png -m generator.pt -o out/v --stochastic --seed 7\n");
  struct Args {
    std::vector<std::string> inputs;
    std::string model, out, mesh, erosion;
    bool png16 = false, r16 = false, preview = false, stochastic = false, running_stats = false;
    std::string precision = "fp32";  // the same heights on every CPU; bf16/auto are faster (docs/BENCHMARKS.md)
    std::string engine = "auto";
    uint64_t seed = 0;
    double exaggeration = 1.0, world_size_m = kCanvasWorldSizeM;
    int size = 0;
    std::optional<int> threads;
  };
  auto a = std::make_shared<Args>();
  sub->add_option("sketches", a->inputs, "Sketch images or folders of them")->required();
  sub->add_option("-m,--model", a->model, "Generator exported by `reefgen train` (RUN/generator.pt)"
                                          "; default: the shipped model (models/reef-256.pt, docs/MODEL.md)");
  sub->add_option("-o,--output,--out", a->out,
                  "One sketch: output prefix (PREFIX.height.exr, PREFIX.json, ...) or NAME.exr (that file, siblings NAME.*). Several: a folder")->required();
  sub->add_flag("--png16", a->png16, "Also PREFIX.height.png: 16-bit linear, range in the sidecar");
  sub->add_flag("--r16", a->r16, "Also PREFIX.r16: little-endian RAW for Unity/Unreal (import numbers printed)");
  sub->add_option("--mesh", a->mesh, "Also a grid mesh: obj or glb (per sketch), or a path ending in .obj/.glb (one sketch)");
  sub->add_option("--exaggeration", a->exaggeration, "Vertical exaggeration of the mesh")->capture_default_str();
  sub->add_option("--world-size", a->world_size_m, "Canvas width in metres (mesh spacing, RAW import numbers)")->capture_default_str()->check(finite_in(1, 1e7));
  sub->add_option("--size", a->size,
                  "Output side in pixels, up to 8192 (default: the sketch's own). Above the model's 256: amplified "
                  "(erosion carves valleys at each finer level, docs/EROSION.md), e.g. 1025/2049/4097 for Unity, "
                  "1009/2017/4033 for Unreal")
      ->check(CLI::Range(16, 8192));
  sub->add_option("--erosion", a->erosion,
                  "JSON of the amplification's erosion params above the model's side (docs/EROSION.md; every key "
                  "optional, e.g. {\"amplify_roughness\": 0.5})");
  sub->add_flag("--preview", a->preview, "Also PREFIX.preview.png: coloured, hill-shaded");
  sub->add_flag("--stochastic", a->stochastic, "Dropout on (pix2pix's noise): a different island per --seed");
  sub->add_option("--seed", a->seed, "Dropout masks for --stochastic")->capture_default_str()->check(seed_value());
  sub->add_option("--precision", a->precision,
                  "fp32, bf16 (heights within ~1 m of fp32, ~1.6x faster), or auto (bf16 where the CPU has "
                  "avx512_bf16 or AMX-bf16, else fp32)")
      ->capture_default_str();
  sub->add_option("--engine", a->engine,
                  "onednn (reefgen's engine), torch (LibTorch's forward, the reference) or auto (onednn; torch "
                  "with --stochastic)")
      ->capture_default_str();
  sub->add_flag("--running-stats", a->running_stats,
                "BatchNorm running statistics (eval mode) instead of pix2pix's test-time batch statistics");
  sub->add_option("--threads", a->threads, "LibTorch threads (default: all cores)")->check(CLI::Range(1, 256));
  return {sub, [a, &g]() -> int {
            torch::set_num_threads(a->threads.value_or(default_threads()));
            train::keep_freed_memory();
            // Inputs: files and the images inside folders, in name order.
            std::vector<fs::path> inputs;
            bool from_folder = false;  // a folder of sketches: -o is a folder even for one sketch (docs/INFERENCE.md)
            for (const auto& s : a->inputs) {
              const fs::path p(s);
              if (fs::is_directory(p)) {
                from_folder = true;
                const std::vector<fs::path> in_dir = images_in(p);
                if (in_dir.empty()) throw Error(p.string() + ": no images (.png, .jpg, ...) in this folder");
                inputs.insert(inputs.end(), in_dir.begin(), in_dir.end());
              } else if (fs::exists(p)) {
                inputs.push_back(p);
              } else {
                throw Error(p.string() + ": no such sketch file or folder");
              }
            }
            const bool many = inputs.size() > 1 || from_folder || fs::is_directory(a->out);
            std::string mesh_format = a->mesh;
            fs::path mesh_path;
            if (!a->mesh.empty() && a->mesh != "obj" && a->mesh != "glb") {
              const std::string ext = fs::path(a->mesh).extension().string();
              if (ext != ".obj" && ext != ".glb") throw Error("--mesh " + a->mesh + ": use obj, glb, or a path ending in .obj or .glb");
              if (many) throw Error("--mesh " + a->mesh + ": a path only works with one sketch; use --mesh obj|glb");
              mesh_path = a->mesh;
              mesh_format = ext.substr(1);
            }
            if (!(a->exaggeration > 0 && a->exaggeration <= 100)) throw Error("--exaggeration must be in (0, 100]");
            if (!(a->world_size_m > 0)) throw Error("--world-size must be > 0");
            a->model = model::resolve_model_path(a->model).string();
            model::GeneratorFile gen = model::load_generator(a->model);
            if (a->stochastic && (gen.g->options().depth < 6 || gen.g->options().dropout == 0))
              throw Error("--stochastic: " + a->model + " has no dropout layers (depth " +
                          std::to_string(gen.g->options().depth) + ", dropout " + std::to_string(gen.g->options().dropout) +
                          "), so outputs cannot vary; drop --stochastic");
            const OutputNames single = many ? OutputNames{} : output_names(a->out);  // -o PREFIX or -o NAME.exr (one sketch)
            const fs::path out_dir = many ? fs::path(a->out) : single.prefix.parent_path();
            {
              // Every file this run may write, checked before any is written:
              // no output may be an input, no two sketches may share a result name.
              std::vector<fs::path> outs;
              std::map<std::string, fs::path> stems;
              for (const auto& in : inputs) {
                const fs::path prefix = many ? out_dir / in.stem() : single.prefix;
                if (!many) outs.push_back(single.height);
                if (many) {
                  const auto [it, fresh] = stems.emplace(in.stem().string(), in);
                  if (!fresh)
                    throw Error(in.string() + " and " + it->second.string() + " would both write " + prefix.string() +
                                ".*; rename one of them or infer them into different -o folders");
                }
                for (const char* ext : {".height.exr", ".height.png", ".r16", ".preview.png", ".json", ".obj", ".glb"})
                  outs.push_back(prefix.string() + ext);
              }
              if (!mesh_path.empty()) outs.push_back(mesh_path);
              refuse_output_over_input(inputs, outs);
            }
            ensure_writable_dir(out_dir.empty() ? fs::path(".") : out_dir);
            std::vector<std::string> r16_notes;
            Progress progress("infer", inputs.size(), g.quiet);
            infer::InferOptions io;
            io.stochastic = a->stochastic;
            io.running_stats = a->running_stats;
            try {
              io.precision = infer::precision_from_string(a->precision);
              io.engine = infer::engine_from_string(a->engine);
              infer::resolve(io, gen);
            } catch (const Error& e) {
              throw Error("--precision/--engine: " + std::string(e.what()));
            }
            io.seed = a->seed;
            io.size_px = a->size;
            io.world_size_m = a->world_size_m;
            if (!a->erosion.empty()) io.erosion = procgen::erosion_params_from_json(read_json(a->erosion), a->erosion);
            // Chunks of 32 sketches: memory stays bounded for folders of any
            // size. Every output is staged and renamed into place at the end:
            // a failure anywhere (a bad sketch after the first chunk, a mesh
            // path in a missing folder) leaves the files of an earlier run
            // exactly as they were and writes nothing.
            constexpr size_t kChunk = 32;
            std::vector<cv::Mat1f> heights;
            StagedOutputs staged;
            std::vector<fs::path> results;
            {
              for (size_t i = 0; i < inputs.size(); ++i) {
                if (i % kChunk == 0) {
                  std::vector<DecodedSketch> sketches;
                  for (size_t k = i; k < std::min(inputs.size(), i + kChunk); ++k) sketches.push_back(read_sketch(inputs[k]));
                  heights = infer::infer_heights(gen, sketches, io);
                }
                const fs::path prefix = many ? out_dir / inputs[i].stem() : single.prefix;
                const cv::Mat1f& h = heights[i % kChunk];
                const double mpp = a->world_size_m / h.cols;
                double hmin, hmax;
                cv::minMaxLoc(h, &hmin, &hmax);
                HeightFiles hf;
                hf.png16 = a->png16;
                hf.r16 = a->r16;
                hf.preview = a->preview;
                hf.mesh = mesh_format;
                hf.mesh_path = mesh_path;
                hf.exaggeration = a->exaggeration;
                const fs::path exr = many ? fs::path(prefix.string() + ".height.exr") : single.height;
                hf.exr_path = exr;
                // The model's range is kept in the sidecar for reference; the
                // 16-bit files span the field's own (stage_height_files).
                nlohmann::json side = {
                    {"reefgen_version", kVersion},
                    {"sketch", fs::absolute(inputs[i]).string()},
                    {"model", {{"path", fs::absolute(a->model).string()}, {"train_step", gen.train_step},
                               {"ngf", gen.g->options().ngf}, {"reefgen_version", gen.reefgen_version}}},
                    {"mode", {{"stochastic", a->stochastic}, {"seed", a->seed},
                              {"batchnorm", a->running_stats ? "running statistics" : "batch statistics"},
                              {"precision", infer::to_string(infer::resolve(io, gen))},
                              {"engine", infer::to_string(infer::resolve_engine(io))}}},
                    {"size_px", {h.cols, h.rows}},
                    {"metres_per_px", mpp},
                    {"height_range_m", {hmin, hmax}},
                    {"model_range_m", {gen.range.lo_m, gen.range.hi_m}}};
                side.update(stage_height_files(staged, prefix, h, mpp, hf));
                if (a->r16)  // printed once the files are in place
                  r16_notes.push_back(prefix.string() + ".r16: " + side["r16"]["import_note"].get<std::string>());
                const fs::path js = prefix.string() + ".json";
                staged.write(js, [&](const fs::path& t) { write_json_atomic(t, side); });  // last of its sketch
                results.push_back(exr);
                progress.tick(i + 1);
              }
            }
            staged.commit();
            if (!g.quiet)
              for (const auto& n : r16_notes) std::fprintf(stderr, "%s", n.c_str());
            for (const auto& r : results) std::printf("%s\n", r.c_str());
            return 0;
          }};
}

}  // namespace reefgen
