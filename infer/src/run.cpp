#include "reefgen/terrain/ocean_floor.hpp"
#include "reefgen/infer/run.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/image_io.hpp"
#include "reefgen/preview.hpp"
#include "reefgen/version.hpp"

namespace reefgen::infer {

SketchInputs sketch_inputs(const std::vector<std::string>& paths) {
  SketchInputs in;
  for (const auto& s : paths) {
    const fs::path p(s);
    if (fs::is_directory(p)) {
      in.from_folder = true;
      const std::vector<fs::path> in_dir = images_in(p);
      if (in_dir.empty()) throw Error(p.string() + ": no images (.png, .jpg, ...) in this folder");
      in.files.insert(in.files.end(), in_dir.begin(), in_dir.end());
    } else if (fs::exists(p)) {
      in.files.push_back(p);
    } else {
      throw Error(p.string() + ": no such sketch file or folder");
    }
  }
  return in;
}

namespace {
// The layers (with the sketch's regions and the network's answer as the
// heights before erosion) and the GeoTIFFs of one sketch, when asked for.
void stage_layers_and_geotiffs(StagedOutputs& staged, const InferJob& job, const std::string& prefix,
                               const cv::Mat1f& h, const std::vector<cv::Mat1f>& before,
                               const std::vector<cv::Mat1b>& labels, size_t k, double mpp, nlohmann::json& side) {
  if (!job.layers && !job.geotiff && job.bundles.empty()) return;
  cv::Mat1b region;
  cv::resize(labels[k], region, h.size(), 0, 0, cv::INTER_NEAREST);
  const terrain::Layers L = terrain::compute_layers(h, before[k], region, mpp, job.layer_params, job.threads);
  if (job.layers) {
    terrain::add_layers_to_sidecar(side, terrain::stage_layer_files(staged, prefix, L, mpp, job.layer_params, job.threads));
  }
  if (job.geotiff) side["geotiff"] = gis::stage_geotiff_files(staged, prefix, h, job.layers ? &L : nullptr, mpp, job.geo, job.threads);
  if (!job.bundles.empty())
    side["bundles"] = engines::stage_bundles(staged, prefix, job.bundles, {h, &L, mpp, job.geo}, job.threads);
}
// The islands side by side, each hill-shaded in its colours at most 512 px
// a side with its seed written in a corner: two columns up to 4 islands,
// then three or four (docs/INFERENCE.md "Variations").
cv::Mat3b variations_sheet(const std::vector<cv::Mat1f>& heights, uint64_t first_seed) {
  const int n = int(heights.size()), cols = n <= 4 ? 2 : n <= 9 ? 3 : 4, rows = (n + cols - 1) / cols;
  const int tile = std::min(512, heights[0].cols);
  cv::Mat3b sheet(rows * tile, cols * tile, cv::Vec3b(255, 255, 255));
  for (int k = 0; k < n; ++k) {
    cv::Mat3b t;
    cv::resize(render_preview(heights[size_t(k)]), t, cv::Size(tile, tile), 0, 0, cv::INTER_AREA);
    const std::string text = "seed " + std::to_string(first_seed + uint64_t(k));
    const double scale = std::max(0.4, tile / 512.0);
    cv::putText(t, text, cv::Point(8, int(24 * scale)), cv::FONT_HERSHEY_SIMPLEX, 0.7 * scale, cv::Scalar(0, 0, 0),
                int(std::ceil(3 * scale)), cv::LINE_AA);
    cv::putText(t, text, cv::Point(8, int(24 * scale)), cv::FONT_HERSHEY_SIMPLEX, 0.7 * scale,
                cv::Scalar(255, 255, 255), int(std::ceil(scale)), cv::LINE_AA);
    t.copyTo(sheet(cv::Rect((k % cols) * tile, (k / cols) * tile, tile, tile)));
  }
  return sheet;
}
// Where a run's files go: -o PREFIX (or NAME.exr) for one sketch, a folder
// for several; variation k of the one sketch at PREFIX.seedS.
struct OutputLayout {
  bool many = false;
  OutputNames single;  // one sketch: its prefix and EXR name
  fs::path out_dir;
  uint64_t first_seed = 0;
  fs::path prefix_of(const fs::path& in) const { return many ? out_dir / in.stem() : single.prefix; }
  fs::path variation_prefix(int k) const {
    return fs::path(single.prefix.string() + ".seed" + std::to_string(first_seed + uint64_t(k)));
  }
  fs::path contact_sheet() const { return single.prefix.string() + ".variations.png"; }
};

OutputLayout output_layout(const InferJob& job) {
  OutputLayout o;
  o.many = job.inputs.files.size() > 1 || job.inputs.from_folder || fs::is_directory(job.out);
  o.single = o.many ? OutputNames{} : output_names(job.out);  // -o PREFIX or -o NAME.exr (one sketch)
  o.out_dir = o.many ? fs::path(job.out) : o.single.prefix.parent_path();
  o.first_seed = job.options.seed;
  return o;
}

// The height files asked for, with --mesh checked (a path names one file).
HeightFiles height_files_of(const InferJob& job, bool many) {
  HeightFiles hf = job.files;
  hf.mesh = job.mesh;
  if (!job.mesh.empty() && job.mesh != "obj" && job.mesh != "glb") {
    const std::string ext = fs::path(job.mesh).extension().string();
    if (ext != ".obj" && ext != ".glb") throw Error("--mesh " + job.mesh + ": use obj, glb, or a path ending in .obj or .glb");
    if (many) throw Error("--mesh " + job.mesh + ": a path only works with one sketch; use --mesh obj|glb");
    hf.mesh_path = job.mesh;
    hf.mesh = ext.substr(1);
  }
  if (!(hf.exaggeration > 0 && hf.exaggeration <= 100)) throw Error("--exaggeration must be in (0, 100]");
  if (job.variations > 1 && !hf.mesh_path.empty())
    throw Error("--variations: --mesh " + job.mesh + " names one file; use --mesh obj|glb (one mesh per island)");
  return hf;
}

// The options the generator and the inputs can honour.
void check_job(const model::GeneratorFile& gen, const InferJob& job, bool many) {
  const InferOptions& io = job.options;
  if (!(io.world_size_m > 0)) throw Error("--world-size must be > 0");
  if (io.stochastic && (gen.g->options().depth < 6 || gen.g->options().dropout == 0))
    throw Error("--stochastic: " + job.model_path + " has no dropout layers (depth " +
                std::to_string(gen.g->options().depth) + ", dropout " + std::to_string(gen.g->options().dropout) +
                "), so outputs cannot vary; drop --stochastic");
  if (job.variations < 1 || job.variations > kMaxVariations)
    throw Error("--variations " + std::to_string(job.variations) + ": expected 1 to " + std::to_string(kMaxVariations));
  check_variation_seeds(io.seed, job.variations);
  if (job.variations > 1 && many)
    throw Error("--variations takes one sketch (" + std::to_string(job.inputs.files.size()) +
                " given, or a folder); infer each sketch with its own -o");
}

// Every file this run may write, checked before any is written: no output
// may be an input, no two sketches may share a result name.
void refuse_overwrites(const InferJob& job, const OutputLayout& o, const HeightFiles& hf) {
  const std::vector<fs::path>& inputs = job.inputs.files;
  engines::PlannedOutputs planned;
  std::map<std::string, fs::path> stems;
  for (const auto& in : inputs) {
    const fs::path prefix = o.prefix_of(in);
    if (o.many) {
      const auto [it, fresh] = stems.emplace(in.stem().string(), in);
      if (!fresh)
        throw Error(in.string() + " and " + it->second.string() + " would both write " + prefix.string() +
                    ".*; rename one of them or infer them into different -o folders");
    } else if (job.variations == 1) {
      planned.files.push_back(o.single.height);
    }
    std::vector<fs::path> prefixes = {prefix};
    if (job.variations > 1) {
      prefixes.clear();
      for (int k = 0; k < job.variations; ++k) prefixes.push_back(o.variation_prefix(k));
      planned.files.push_back(o.contact_sheet());
    }
    for (const fs::path& p : prefixes) {
      const engines::PlannedOutputs mine = engines::planned_outputs(p, job.bundles);
      planned.files.insert(planned.files.end(), mine.files.begin(), mine.files.end());
      planned.folders.insert(planned.folders.end(), mine.folders.begin(), mine.folders.end());
    }
  }
  if (!hf.mesh_path.empty()) planned.files.push_back(hf.mesh_path);
  engines::refuse_outputs_over_inputs(inputs, planned);
}

// The mode every sidecar records (resolve throws for impossible pairs).
// A generator without BatchNorm (the shipped one: instance norm) has no
// running statistics: --running-stats changes nothing there, and says so.
nlohmann::json sidecar_mode(const model::GeneratorFile& gen, const InferOptions& io) {
  const model::Norm norm = gen.g->options().norm;
  const std::string batchnorm =
      norm != model::Norm::Batch
          ? "none (the generator uses " + std::string(norm == model::Norm::Instance ? "instance norm" : "no normalisation") + ")"
      : io.running_stats ? "running statistics"
                         : "batch statistics";
  nlohmann::json mode = {{"stochastic", io.stochastic}, {"seed", io.seed},         {"variation", io.variation},
                         {"batchnorm", batchnorm},      {"precision", to_string(resolve(io, gen))},
                         {"engine", to_string(resolve_engine(io))}};
  // The age and maturity asked for, and what they set (reefgen/age.hpp).
  if (io.age_myr != kNotSet) mode["age_myr"] = io.age_myr, mode["subsidence"] = subsidence_of_age(io.age_myr);
  if (const double m = maturity_for(io.age_myr, io.maturity); m != kNotSet) mode["maturity"] = m;
  return mode;
}

// Sketches [first, first + count) read and checked against what is asked of
// their output; a sketch much larger than the model's side gets a note.
std::vector<DecodedSketch> read_sketches(const model::GeneratorFile& gen, const InferJob& job, size_t first,
                                         size_t count, std::vector<std::string>& world_notes) {
  const InferOptions& io = job.options;
  std::vector<DecodedSketch> sketches;
  for (size_t k = first; k < first + count; ++k) {
    const fs::path& in = job.inputs.files[k];
    sketches.push_back(read_sketch(in));
    const cv::Size sz = sketches.back().label.size();
    // The output is the sketch's size unless --size: its layers and
    // bundles take at least 2 samples a side, the bundles a square.
    const cv::Size out = io.size_px > 0 ? cv::Size(io.size_px, io.size_px) : sz;
    const std::string would = in.string() + ": the output would be " + std::to_string(out.width) + "x" +
                              std::to_string(out.height) + "; ";
    if (std::min(out.width, out.height) < 2 && (job.layers || job.geotiff || !job.bundles.empty()))
      throw Error(would + "layers, GeoTIFFs and engine bundles need at least 2 samples a side: pass --size N "
                          "(e.g. --size 257)");
    if (out.width != out.height && !job.bundles.empty())
      throw Error(would + "engine bundles take a square field: pass --size N (e.g. --size 257)");
    if (std::max(sz.width, sz.height) > kWorldHintSidePx)
      world_notes.push_back(in.string() + ": " + std::to_string(sz.width) + "x" + std::to_string(sz.height) +
                            " read as one " + std::to_string(int(io.world_size_m / 1000)) +
                            " km island (resized to the model's " + std::to_string(gen.size_px) +
                            "²); `reefgen world` reads it at the model's scale, " +
                            std::to_string(int(std::lround(sz.width * kModelMetresPerPx / 1000))) + " km across");
  }
  return sketches;
}

// One island's sidecar before its files are staged into it.
nlohmann::json island_sidecar(const model::GeneratorFile& gen, const InferJob& job, const fs::path& sketch,
                              const nlohmann::json& mode, uint64_t seed, const cv::Mat1f& h, double mpp) {
  double hmin, hmax;
  cv::minMaxLoc(h, &hmin, &hmax);
  nlohmann::json island_mode = mode;
  island_mode["seed"] = seed;
  // The model's range is kept for reference; the 16-bit files span the
  // field's own (stage_height_files).
  nlohmann::json side = {
      {"reefgen_version", kVersion},
      {"sketch", fs::absolute(sketch).string()},
      {"model", {{"path", fs::absolute(job.model_path).string()}, {"train_step", gen.train_step},
                 {"ngf", gen.g->options().ngf}, {"reefgen_version", gen.reefgen_version}}},
      {"mode", island_mode},
      {"size_px", {h.cols, h.rows}},
      {"metres_per_px", mpp},
      {"height_range_m", {hmin, hmax}},
      {"model_range_m", {gen.range.lo_m, gen.range.hi_m}}};
  if (job.options.ocean_floor_m < 0) side["ocean_floor_m"] = job.options.ocean_floor_m;
  return side;
}
}  // namespace

InferResult infer_files(model::GeneratorFile& gen, const InferJob& job,
                        const std::function<void(size_t)>& done) {
  const std::vector<fs::path>& inputs = job.inputs.files;
  if (inputs.empty()) throw Error("infer: no sketches given");
  const OutputLayout layout = output_layout(job);
  HeightFiles hf = height_files_of(job, layout.many);
  check_job(gen, job, layout.many);
  refuse_overwrites(job, layout, hf);
  ensure_writable_dir(layout.out_dir.empty() ? fs::path(".") : layout.out_dir);
  const InferOptions& io = job.options;
  const int variations = job.variations;
  const nlohmann::json mode = sidecar_mode(gen, io);
  constexpr size_t kChunk = 32;
  if (job.geotiff) gis::check_crs(job.geo.crs);
  std::vector<cv::Mat1f> heights, before;
  std::vector<cv::Mat1b> labels;
  StagedOutputs staged;
  InferResult r;
  // Stage lines for a large island: the amplification runs for seconds to
  // half a minute without another sign of life.
  const bool stage_lines = !job.quiet && io.size_px >= kStageLinesSidePx;
  const auto stage = [&](const char* what, std::chrono::steady_clock::time_point since) {
    if (stage_lines)
      std::fprintf(stderr, "infer: %s in %.1f s\n", what,
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count());
  };
  for (size_t i = 0; i < inputs.size(); ++i) {
    if (i % kChunk == 0) {
      const std::vector<DecodedSketch> sketches =
          read_sketches(gen, job, i, std::min(inputs.size(), i + kChunk) - i, r.world_notes);
      const size_t islands = variations > 1 ? size_t(variations) : sketches.size();
      if (stage_lines)
        std::fprintf(stderr, "infer: %zu island%s to %d² (network answer, clean-up, amplification) ...\n", islands,
                     islands == 1 ? "" : "s", io.size_px);
      const auto t_amplify = std::chrono::steady_clock::now();
      before.clear();
      labels.clear();
      std::vector<cv::Mat1f>* keep_before = job.layers || job.geotiff || !job.bundles.empty() ? &before : nullptr;
      if (variations > 1) {
        labels.assign(size_t(variations), sketches[0].label);
        heights = infer_variations(gen, sketches[0], io, variations, job.threads, keep_before);
      } else {
        for (const auto& s : sketches) labels.push_back(s.label);
        heights = infer_heights(gen, sketches, io, keep_before);
      }
      if (io.ocean_floor_m < 0) {
        for (size_t k = 0; k < heights.size(); ++k)
          terrain::deepen_flank(heights[k], io.ocean_floor_m, io.world_size_m / heights[k].cols, labels[k]);
        for (size_t k = 0; k < before.size(); ++k)
          terrain::deepen_flank(before[k], io.ocean_floor_m, io.world_size_m / before[k].cols, labels[k]);
      }
      stage("amplified", t_amplify);
    }
    const auto t_files = std::chrono::steady_clock::now();
    // Island k of the chunk's answers (variation k of the one sketch).
    const auto write_island = [&](size_t k, const fs::path& prefix, const fs::path& exr, uint64_t seed) {
      const cv::Mat1f& h = heights[k];
      const double mpp = io.world_size_m / h.cols;
      hf.exr_path = exr;
      nlohmann::json side = island_sidecar(gen, job, inputs[i], mode, seed, h, mpp);
      side.update(stage_height_files(staged, prefix, h, mpp, hf));
      stage_layers_and_geotiffs(staged, job, prefix.string(), h, before, labels, k, mpp, side);
      if (hf.r16) r.r16_notes.push_back(prefix.string() + ".r16: " + side["r16"]["import_note"].get<std::string>());
      staged.write(prefix.string() + ".json", [&](const fs::path& t) { write_json_atomic(t, side); });  // last of its island
      r.heights.push_back(exr);
    };
    if (variations > 1) {
      for (int k = 0; k < variations; ++k) {
        const fs::path prefix = layout.variation_prefix(k);
        write_island(size_t(k), prefix, prefix.string() + ".height.exr", io.seed + uint64_t(k));
      }
      const cv::Mat3b sheet = variations_sheet(heights, io.seed);
      staged.write(layout.contact_sheet(), [&](const fs::path& t) { write_png(t, sheet); });
    } else {
      const fs::path prefix = layout.prefix_of(inputs[i]);
      write_island(i % kChunk, prefix, layout.many ? fs::path(prefix.string() + ".height.exr") : layout.single.height,
                   io.seed);
    }
    stage("files staged", t_files);
    if (done) done(i + 1);
  }
  staged.commit();
  r.files = staged.finals();
  return r;
}

}  // namespace reefgen::infer
