#include "reefgen/procgen/output.hpp"

#include <atomic>
#include <cstdio>
#include <future>
#include <optional>

#include "reefgen/io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/parallel.hpp"
#include "reefgen/preview.hpp"
#include "reefgen/procgen/random_spec.hpp"
#include "reefgen/version.hpp"

namespace reefgen::procgen {

namespace {
// The island's sidecar before its files' sizes and layers are known.
nlohmann::json island_sidecar(const IslandSpec& spec, int W, double mpp, double hmin, double hmax,
                              const nlohmann::json& files, const nlohmann::json& provenance) {
  return {{"tool", "reefgen"},
          {"version", kVersion},
          {"kind", "island"},
          {"size_px", W},
          {"metres_per_pixel", mpp},
          {"world_size_m", spec.world_size_m},
          {"sea_level_m", 0.0},
          {"height_range_m", {hmin, hmax}},
          {"height_channel", "Y"},
          {"subsidence", spec.subsidence},
          {"label_encoding", "HSV: hue 60*(id+1) deg for island, beach, lagoon, reef; 0 deg abyss; V = 1 - 0.75*subsidence"},
          {"files", files},
          {"provenance", provenance},
          {"spec", spec}};
}
}  // namespace

WrittenIsland write_island(const std::filesystem::path& prefix, const IslandFields& f, const IslandSpec& spec,
                           const nlohmann::json& provenance, bool preview, const std::filesystem::path& height_given,
                           const terrain::LayerParams* layers, int threads, const ExtraFiles& extra,
                           bool layer_files) {
  const int W = f.height_m.cols;
  double hmin, hmax;
  cv::minMaxLoc(f.height_m, &hmin, &hmax);
  const double mpp = spec.world_size_m / W;
  auto name = [&](const char* suffix) {
    std::filesystem::path p = prefix;
    p += suffix;
    return p;
  };
  WrittenIsland out;
  const auto height_path = height_given.empty() ? name(".height.exr") : height_given, label_path = name(".label.png"), preview_path = name(".preview.png"),
             json_path = name(".json");
  nlohmann::json files = {{"height", height_path.filename().string()}, {"label", label_path.filename().string()}};
  if (preview) files["preview"] = preview_path.filename().string();
  // The rain the erosion read, a layer beside the others (docs/LAYERS.md "Rain").
  const bool rain_file = layers && layer_files && !f.rain_mm_yr.empty();
  const auto rain_path = name(terrain::kRainFileSuffix);
  if (rain_file) files["rain"] = rain_path.filename().string();
  out.sidecar = island_sidecar(spec, W, mpp, hmin, hmax, files, provenance);

  ExrAttributes attrs = {{"reefgen:version", kVersion},
                         {"reefgen:units", "metres, sea level 0"},
                         {"reefgen:metres_per_pixel", std::to_string(mpp)},
                         {"reefgen:sidecar", json_path.filename().string()}};
  // All or nothing: the files are staged and renamed into place together, so
  // a failure (a folder where the preview goes, a full disk) leaves an earlier
  // island of this name exactly as it was, and no half-written new one.
  StagedOutputs staged;
  // The layers are computed while the height, label and preview files are
  // encoded (the drainage routing is sequential; the EXR's zip is too).
  std::future<terrain::Layers> layer_job;
  if (layers)
    layer_job = std::async(std::launch::async, [&] {
      return terrain::compute_layers(f.height_m, f.uneroded_m, f.label, mpp, *layers, threads);
    });
  // Each file's size goes into the sidecar: a resume (write_random_islands)
  // then tells a complete island from one whose file was truncated since.
  nlohmann::json bytes = nlohmann::json::object();
  staged.write(height_path, [&](const fs::path& p) {
    write_exr_height(p, f.height_m, attrs);
    bytes["height"] = fs::file_size(p);
  });
  staged.write(label_path, [&](const fs::path& p) {
    write_png(p, encode_labels(f.label, spec.subsidence));
    bytes["label"] = fs::file_size(p);
  });
  if (preview) {
    PreviewOptions po;
    po.land_top_m = spec.heights.peak_m;
    po.sea_floor_m = spec.heights.floor_m;
    po.metres_per_px = mpp;
    staged.write(preview_path, [&](const fs::path& p) {
      write_png(p, render_preview(f.height_m, po));
      bytes["preview"] = fs::file_size(p);
    });
  }
  if (rain_file) bytes["rain"] = terrain::stage_rain_file(staged, prefix.string(), f.rain_mm_yr, mpp);
  std::optional<terrain::Layers> L;
  if (layers) {
    L = layer_job.get();
    if (layer_files)
      terrain::add_layers_to_sidecar(out.sidecar,
                                     terrain::stage_layer_files(staged, prefix.string(), *L, mpp, *layers, threads));
  }
  if (extra) extra(staged, out.sidecar, L ? &*L : nullptr);
  out.sidecar["file_bytes"] = bytes;
  staged.write(json_path, [&](const fs::path& p) { write_json_atomic(p, out.sidecar); });  // last
  staged.commit();
  out.files = staged.finals();
  return out;
}

RandomIslandsResult write_random_islands(const std::filesystem::path& dir, const RandomIslands& r,
                                         const std::function<void(size_t)>& progress) {
  namespace fs = std::filesystem;
  if (r.count < 1 || r.count > 10'000'000) throw Error("random islands: count must be in 1..10000000");
  if (r.levels < 1 || r.levels > 64) throw Error("random islands: levels must be in 1..64");
  const auto levels = subsidence_levels(r.levels);
  RandomIslandsResult res;
  res.total = static_cast<size_t>(r.count) * levels.size();
  std::atomic<size_t> skipped{0};
  parallel_for(
      res.total, r.threads,
      [&](size_t t) {
        const size_t index = t / levels.size(), level = t % levels.size();
        char name[64];
        std::snprintf(name, sizeof name, "island_%06zu_l%zu", index, level);
        const fs::path prefix = dir / name;
        fs::path sidecar = prefix;
        sidecar += ".json";
        // The sidecar is written last: if it is there, this island is complete
        // (a rerun after an interruption resumes here) unless it is foreign.
        if (fs::exists(sidecar)) {
          const auto j = read_json(sidecar);
          const auto& p = j.value("provenance", nlohmann::json::object());
          if (!(p.value("seed", ~0ull) == r.seed && p.value("index", ~0ull) == index &&
                j.value("size_px", 0) == r.render.size_px && j.value("subsidence", -1.0) == levels[level]))
            throw Error(sidecar.string() + " was made with other settings; use an empty --out folder");
          bool complete = true;
          const nlohmann::json files = j.value("files", nlohmann::json::object());
          const nlohmann::json bytes = j.value("file_bytes", nlohmann::json::object());
          for (const auto& [kind, file] : files.items()) {
            std::error_code ec;
            const fs::path fp = file.is_string() ? dir / file.get<std::string>() : fs::path();
            complete = complete && file.is_string() && fs::exists(fp, ec);
            // A file cut short since (a full disk, a copy interrupted): made again.
            if (complete && bytes.contains(kind) && bytes[kind].is_number_unsigned())
              complete = fs::file_size(fp, ec) == bytes[kind].get<uintmax_t>() && !ec;
          }
          if (complete) {
            ++skipped;
            return;
          }
        }
        IslandSpec spec = random_spec(r.seed, index);
        spec.subsidence = levels[level];
        RenderOptions render = r.render;
        render.keep_uneroded = r.layers;
        const IslandFields f = generate(spec, render);
        write_island(prefix, f, spec,
                     {{"mode", "random"}, {"seed", r.seed}, {"index", index}, {"level", level}, {"warp_grid", r.render.warp_grid}},
                     r.preview, {}, r.layers ? &r.layer_params : nullptr);
      },
      [&](size_t done) {
        if (progress) progress(done);
      });
  res.skipped = skipped;
  return res;
}

}  // namespace reefgen::procgen
