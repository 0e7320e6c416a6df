#include "reefgen/infer/world_run.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <optional>

#include <opencv2/imgproc.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/engines/world_bundle.hpp"
#include "reefgen/error.hpp"
#include "reefgen/infer/amplify.hpp"
#include "reefgen/infer/reef_details.hpp"
#include "reefgen/infer/variation.hpp"
#include "reefgen/infer/world.hpp"
#include "reefgen/io.hpp"
#include "reefgen/parallel.hpp"
#include "reefgen/sha256.hpp"
#include "reefgen/terrain/ocean_floor.hpp"
#include "reefgen/version.hpp"

namespace reefgen::infer {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}


// An interrupted world's finished work, kept beside it in PREFIX.partial/ for
// the same command to resume: the model's answer and the amplified heights,
// and every output file written so far (a resumable StagedOutputs). A
// different command (another sketch, size, seed, model or finishing flag)
// starts again.
class WorldCheckpoint {
 public:
  // The mark of a checkpoint this command made: the only kind it removes.
  static constexpr const char* kKind = "reefgen world checkpoint";

  WorldCheckpoint(const fs::path& prefix, nlohmann::json key, bool quiet) : dir_(prefix.string() + ".partial") {
    key["kind"] = kKind;
    std::error_code ec;
    const fs::path key_file = dir_ / "key.json";
    // What a run killed while it removed its checkpoint left (remove()).
    if (fs::symlink_status(removing(), ec).type() == fs::file_type::directory) fs::remove_all(removing(), ec);
    const auto type = fs::symlink_status(dir_, ec).type();
    if (type != fs::file_type::not_found) {
      refuse_unless_ours(type, key_file);
      // Killed between making the folder and writing its key: nothing to resume.
      resumed_ = fs::symlink_status(key_file, ec).type() == fs::file_type::regular && read_json(key_file) == key;
      if (!resumed_ && !quiet && !fs::is_empty(dir_, ec))
        std::fprintf(stderr, "note: %s holds another world's work; starting again\n", dir_.c_str());
    }
    if (!resumed_) {
      remove();
      ensure_writable_dir(dir_);
      write_json_atomic(key_file, key);
    }
  }
  bool resumed() const { return resumed_; }
  const fs::path& dir() const { return dir_; }
  // Whether anything but the key is in it: a refusal before any work (a
  // size, a scale) leaves nothing to resume.
  bool holds_work() const {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir_, ec))
      if (e.path().filename() != "key.json") return true;
    return false;
  }
  // Renamed away first (one atomic step), then deleted: a run killed while
  // remove_all ran left a PREFIX.partial without its key.json, or with only
  // some of its files, which no rerun would take as its own again.
  void remove() const {
    std::error_code ec;
    fs::rename(dir_, removing(), ec);
    fs::remove_all(ec ? dir_ : removing(), ec);
  }
  // A field saved by an earlier run of this command, if any, and intact
  // (the checksum recorded when it was saved); else it is made again.
  std::optional<cv::Mat1f> load(const std::string& name) const {
    if (!resumed_ || !intact(name)) return std::nullopt;
    try {
      return read_exr_height(dir_ / name);
    } catch (const Error&) {
      return std::nullopt;
    }
  }
  // Uncompressed: a 16385² field is written in seconds. The record last.
  void save(const std::string& name, const cv::Mat1f& field) const {
    write_exr_height(dir_ / name, field, {}, 0);
    write_text_atomic(dir_ / (name + ".sha256"), sha256_of_file((dir_ / name).string()) + "\n");
  }

 private:
  // PREFIX.partial is removed or reused only when this command made it: a
  // folder holding our key.json, or an empty folder (killed before its key).
  void refuse_unless_ours(fs::file_type type, const fs::path& key_file) const {
    std::error_code ec;
    bool ours = type == fs::file_type::directory && fs::is_empty(dir_, ec);
    if (!ours && type == fs::file_type::directory && fs::symlink_status(key_file, ec).type() == fs::file_type::regular) {
      try {
        const nlohmann::json k = read_json(key_file);
        ours = k.is_object() && k.value("kind", "") == kKind;
      } catch (const Error&) {
      }
    }
    if (!ours)
      throw Error(dir_.string() + ": exists and is not a checkpoint of `reefgen world` (it would be deleted); move it "
                  "away or choose another -o");
  }
  bool intact(const std::string& name) const {
    std::error_code ec;
    const fs::path f = dir_ / name, rec = dir_ / (name + ".sha256");
    if (fs::symlink_status(f, ec).type() != fs::file_type::regular) return false;
    if (fs::symlink_status(rec, ec).type() != fs::file_type::regular) return false;
    std::ifstream in(rec);
    std::string recorded;
    std::getline(in, recorded);
    return !recorded.empty() && recorded == sha256_of_file(f.string());
  }

  fs::path removing() const { return dir_.parent_path() / ("." + dir_.filename().string() + ".removing"); }

  fs::path dir_;
  bool resumed_ = false;
};

// What a world's bytes depend on: a checkpoint is resumed only by the same.
nlohmann::json world_key(const WorldJob& a, const std::string& model_path, int64_t train_step) {
  const std::string sketch = read_text(a.sketch.string(), size_t(256) << 20);
  // The model by its bytes: another file of the same name and step is another model.
  const std::string model_sha256 = sha256_of_file(model_path);
  if (model_sha256.empty()) throw Error(model_path + ": cannot read the model (check the path and its permissions)");
  // The program by its bytes too: a checkpoint an older reefgen left holds
  // heights its code computed, and a resume would mix two versions' work.
  return {{"sketch_sha256", sha256_hex(sketch.data(), sketch.size())},
          {"program_sha256", sha256_of_file("/proc/self/exe")},
          {"model", fs::absolute(model_path).string()},
          {"model_sha256", model_sha256},
          {"train_step", train_step},
          {"size", a.size},
          {"sketch_metres_per_px", a.sketch_metres_per_px},
          {"seed", a.options.seed},
          {"variation", a.options.variation},
          {"layer_rules", a.layer_rules},
          {"age_myr", a.options.age_myr},
          {"maturity", a.options.maturity},
          {"raw", a.raw},
          {"ocean_floor_m", a.ocean_floor_m},
          {"precision", to_string(a.options.precision)},
          {"engine", to_string(a.options.engine)},
          {"flags", a.flags_key},
          {"version", kVersion}};
}

// Past kMaxWholeAmplifySidePx a world is made in bands and written in tiles
// (engines/world_bundle.hpp): the bundles without a tiled form are refused
// before any work, as are the engine bundles of a world that is not square.
void check_finish(const WorldJob& job, int side, bool square) {
  if (!square)
    for (const auto e : job.bundles)
      if (e != engines::Engine::Gis)
        throw Error("--for " + std::string(engines::to_string(e)) +
                    ": the engine bundles take square worlds (the sketch is not square); use a square sketch, or "
                    "--for gis (GeoTIFF tiles of any shape)");
  if (side <= kMaxWholeAmplifySidePx) return;
  for (const auto e : job.bundles)
    if (!engines::has_world_bundle(e))
      throw Error("--for " + std::string(engines::to_string(e)) + ": a world past " +
                  std::to_string(kMaxWholeAmplifySidePx) + "² is written in tiles, and " + engines::to_string(e) +
                  " takes one file (" + std::to_string(side) + "² asked); use --size " +
                  std::to_string(kMaxWholeAmplifySidePx) + ", or --for unity, unreal, godot or gis");
}

// A world past one file per layer: its layers and bundles in tiles, each
// tile's layers made from one field of the whole world as it is written.
void stage_world_tiles(StagedOutputs& staged, const WorldJob& a,
                       const std::string& prefix, const cv::Mat1f& h, const cv::Mat1f& model_h,
                       const cv::Mat1b& region_model, double mpp, int threads, bool quiet, nlohmann::json& side) {
  std::optional<terrain::WorldLayerField> field;
  if (a.need_layers) {
    const auto t = std::chrono::steady_clock::now();
    field = terrain::world_layer_field(h, model_h, region_model, mpp, a.layer_rules, threads);
    if (!quiet) std::fprintf(stderr, "world: layer field (drainage, sediment, regions) in %.1f s\n", seconds_since(t));
  }
  const std::string name = fs::path(prefix).filename().string();
  const engines::WorldInput in{h, field ? &*field : nullptr, mpp, a.geo, a.layer_rules};
  if (a.layers) {
    if (!quiet) std::fprintf(stderr, "world: layers in tiles ...\n");
    side["layers"] = engines::stage_world_layers(staged, prefix + ".layers", name, in, a.geotiff, threads);
    side["files"]["layers"] = fs::path(prefix + ".layers").filename().string();
  }
  if (a.geotiff) side["geotiff"] = gis::stage_geotiff_files(staged, prefix, h, nullptr, mpp, a.geo, threads);
  for (const auto e : a.bundles) {
    if (!quiet) std::fprintf(stderr, "world: %s bundle in tiles ...\n", engines::to_string(e));
    engines::WorldInput bin = in;
    // The gis bundle carries the float layers when the layers are asked for.
    if (e == engines::Engine::Gis && !a.layers) bin.field = nullptr;
    side["bundles"][engines::to_string(e)] =
        engines::stage_world_bundle(staged, prefix + "." + engines::to_string(e), name, e, bin, threads);
  }
}

// The world's layers, GeoTIFFs and bundles, staged beside its heights: one
// file per layer up to kMaxWholeAmplifySidePx, tiles past it.
void stage_world_finish(StagedOutputs& staged, const WorldJob& a,
                        const std::string& prefix, const cv::Mat1f& h, const cv::Mat1f& model_h,
                        const cv::Mat1b& region_model, double mpp, int threads, bool quiet, nlohmann::json& side) {
  if (std::max(h.cols, h.rows) > kMaxWholeAmplifySidePx)
    return stage_world_tiles(staged, a, prefix, h, model_h, region_model, mpp, threads, quiet, side);
  std::vector<engines::Engine> bundles = a.bundles;
  const auto gis = std::find(bundles.begin(), bundles.end(), engines::Engine::Gis);
  if (gis != bundles.end() && (h.cols > gis::kGeoTiffTileMaxPx || h.rows != h.cols)) {
    const engines::WorldInput in{h, nullptr, mpp, a.geo, a.layer_rules};
    side["bundles"]["gis"] = engines::stage_world_bundle(staged, prefix + ".gis", fs::path(prefix).filename().string(),
                                                         engines::Engine::Gis, in, threads);
    bundles.erase(gis);
  }
  if (!a.need_layers && !a.geotiff && bundles.empty()) return;
  cv::Mat1b region;
  cv::resize(region_model, region, h.size(), 0, 0, cv::INTER_NEAREST);
  cv::Mat1f before;
  cv::resize(model_h, before, h.size(), 0, 0, cv::INTER_CUBIC);
  std::optional<terrain::Layers> L;
  if (a.need_layers && (a.layers || !bundles.empty())) L = terrain::compute_layers(h, before, region, mpp, a.layer_rules, threads);
  before.release();
  if (a.layers)
    terrain::add_layers_to_sidecar(side, terrain::stage_layer_files(staged, prefix, *L, mpp, a.layer_rules, threads));
  if (a.geotiff)
    side["geotiff"] = gis::stage_geotiff_files(staged, prefix, h, a.layers ? &*L : nullptr, mpp, a.geo, threads);
  if (!bundles.empty())
    side["bundles"].update(engines::stage_bundles(staged, prefix, bundles, {h, L ? &*L : nullptr, mpp, a.geo}, threads));
}
// The world's fields: the model's answer at its scale, the regions there,
// and the finished heights (amplified unless --raw). Each is taken from the
// checkpoint when an earlier run of this command made it.
struct WorldFields {
  cv::Mat1f model_h, h;
  cv::Mat1b region_model;
  double world_m = 0;
};

WorldFields world_fields(const WorldJob& a, model::GeneratorFile& gen, const DecodedSketch& s,
                         const WorldCheckpoint& checkpoint) {
  const bool quiet = a.quiet;
  const InferOptions& io = a.options;
  WorldFields w;
  auto t = std::chrono::steady_clock::now();
  const std::optional<cv::Mat1f> saved_model = checkpoint.load("model.exr");
  w.model_h = saved_model ? *saved_model : world_model_heights(gen, s, a.sketch_metres_per_px, io);
  if (!saved_model) checkpoint.save("model.exr", w.model_h);
  if (!quiet)
    std::fprintf(stderr, "world: %dx%d px at %.1f m (%.1f km across), model pass %.1f s%s\n", w.model_h.cols,
                 w.model_h.rows, kModelMetresPerPx, w.model_h.cols * kModelMetresPerPx / 1000, seconds_since(t),
                 saved_model ? " (resumed)" : "");
  w.world_m = w.model_h.cols * kModelMetresPerPx;
  cv::resize(s.label, w.region_model, w.model_h.size(), 0, 0, cv::INTER_NEAREST);
  w.h = w.model_h;
  // The flank below the training range, on the whole world at once (the
  // checkpoint keeps the heights before it: the same for any depth).
  auto deepened = [&a](WorldFields& f) {
    if (a.ocean_floor_m < 0) terrain::deepen_flank(f.h, a.ocean_floor_m, f.world_m / f.h.cols, f.region_model);
    return f;
  };
  if (a.raw) return deepened(w);
  // Passes and motu where the painting shows none, placed by the seed: the
  // motu on the regions (so the layers see their sand), the passes cut
  // after the amplification (a resumed run's heights have them already).
  const SeededReefDetails details =
      plan_reef_details(w.region_model, s.subsidence, kModelMetresPerPx, io.seed, io.variation);
  paint_seeded_motu(w.region_model, details, kModelMetresPerPx);
  if (auto saved = checkpoint.load("heights.exr")) {
    w.h = *saved;
    if (!quiet) std::fprintf(stderr, "world: amplified heights resumed from %s\n", checkpoint.dir().c_str());
    return deepened(w);
  }
  const int N = a.size > 0 ? a.size : std::max(w.model_h.cols, w.model_h.rows);
  if (!quiet)
    for (const auto e : a.bundles) {
      const std::string note = N <= kMaxWholeAmplifySidePx ? engines::size_note(e, N, "--size") : engines::world_size_note(e, N);
      if (!note.empty()) std::fprintf(stderr, "note: %s\n", note.c_str());
    }
  t = std::chrono::steady_clock::now();
  if (!quiet) std::fprintf(stderr, "world: amplifying to %d² ...\n", N);
  Progress progress("world: last level, bands", size_t((N + kWorldBandRowsPx - 1) / kWorldBandRowsPx), quiet);
  // Every island re-rolled by the seed, then eroded anew at every size, as infer does.
  const Rerolled r = reroll_for_amplify(w.model_h, kModelMetresPerPx, io.seed, io.variation, amplification_of(io));
  w.h = amplify_world(r.height_m, w.region_model, N, w.world_m, io.seed, r.params,
                             [&](int done, int) { progress.tick(size_t(done)); }, {}, s.ruggedness);
  cut_seeded_passes(w.h, w.region_model, details, kModelMetresPerPx * w.model_h.cols / w.h.cols, io.seed);
  cv::min(cv::max(w.h, gen.range.lo_m), gen.range.hi_m, w.h);
  if (!quiet) std::fprintf(stderr, "world: amplified to %d² in %.1f s\n", w.h.cols, seconds_since(t));
  checkpoint.save("heights.exr", w.h);
  return deepened(w);
}

// Every file of the world, staged in the checkpoint (kept there if the run
// stops) and moved into place together; then the checkpoint goes.
void write_world(const WorldJob& a, const WorldFields& w, int64_t train_step, const WorldCheckpoint& checkpoint) {
  const fs::path& prefix = a.prefix;
  const std::string& model_path = a.model_path;
  const int threads = a.threads;
  const bool quiet = a.quiet;
  const cv::Mat1f& h = w.h;
  const double mpp = w.world_m / h.cols;
  double hmin, hmax;
  cv::minMaxLoc(h, &hmin, &hmax);
  nlohmann::json side = {{"reefgen_version", kVersion},
                         {"sketch", fs::absolute(a.sketch).string()},
                         {"model", {{"path", fs::absolute(model_path).string()}, {"train_step", train_step}}},
                         {"world", {{"sketch_metres_per_px", a.sketch_metres_per_px},
                                    {"model_metres_per_px", kModelMetresPerPx},
                                    {"model_side_px", {w.model_h.cols, w.model_h.rows}},
                                    {"raw", a.raw},
                                    {"seed", a.options.seed},
                                    {"variation", a.options.variation},
                                    {"age_myr", a.options.age_myr == kNotSet ? nlohmann::json() : nlohmann::json(a.options.age_myr)},
                                    {"maturity", a.options.maturity == kNotSet ? nlohmann::json() : nlohmann::json(a.options.maturity)}}},
                         {"ocean_floor_m", a.ocean_floor_m < 0 ? nlohmann::json(a.ocean_floor_m) : nlohmann::json()},
                         {"size_px", {h.cols, h.rows}},
                         {"metres_per_px", mpp},
                         {"height_range_m", {hmin, hmax}}};
  const HeightFiles& hf = a.files;
  const auto t = std::chrono::steady_clock::now();
  StagedOutputs staged(checkpoint.dir() / "files", prefix.has_parent_path() ? prefix.parent_path() : fs::path("."));
  side.update(stage_height_files(staged, prefix, h, mpp, hf));
  stage_world_finish(staged, a, prefix.string(), h, w.model_h, w.region_model, mpp, threads, quiet, side);
  staged.write(prefix.string() + ".json", [&](const fs::path& tmp) { write_json_atomic(tmp, side); });
  staged.commit();
  checkpoint.remove();
  if (!quiet)
    std::fprintf(stderr, "world: files written in %.1f s%s\n", seconds_since(t),
                 staged.resumed_count() ? (" (" + std::to_string(staged.resumed_count()) + " resumed)").c_str() : "");
  for (const auto& f : staged.finals()) std::printf("%s\n", f.c_str());
}
}  // namespace

void refuse_world_over_sketch(const WorldJob& job) {
  engines::refuse_outputs_over_inputs({job.sketch}, engines::planned_outputs(job.prefix, job.bundles));
}

void check_world_finish(const WorldJob& job, bool square) { check_finish(job, job.size, square); }

void run_world(model::GeneratorFile& gen, const DecodedSketch& sketch, const WorldJob& job) {
  // Two runs with one -o would remove each other's checkpoint and stage into
  // one folder: the second is refused.
  const fs::path out_dir = job.prefix.has_parent_path() ? job.prefix.parent_path() : fs::path(".");
  const DirLock lock(out_dir, "world's outputs (" + job.prefix.filename().string() + ")",
                     "." + job.prefix.filename().string() + ".world.lock", true);
  const WorldCheckpoint checkpoint(job.prefix, world_key(job, job.model_path, gen.train_step), job.quiet);
  try {
    // The age as infer applies it: its subsidence over the painted one (the
    // amplification is matured and the network's maturity read from the options).
    const WorldFields w = world_fields(job, gen, with_age(sketch, job.options.age_myr), checkpoint);
    write_world(job, w, gen.train_step, checkpoint);
  } catch (const Error& e) {
    if (!checkpoint.holds_work()) {
      checkpoint.remove();
      throw;
    }
    throw Error(std::string(e.what()) + " (the work so far is kept in " + checkpoint.dir().string() +
                ": the same command resumes it)");
  }
}

}  // namespace reefgen::infer
