// reefgen erode HEIGHTMAP: the project's erosion (docs/EROSION.md) and the
// layers (docs/LAYERS.md) for a heightmap the user brings, at its own size.
#include <cmath>
#include <cstdio>
#include <optional>

#include "app.hpp"
#include "reefgen/terrain/ocean_floor.hpp"
#include "reefgen/constants.hpp"
#include "finish.hpp"
#include "reefgen/gis/geotiff.hpp"
#include "reefgen/gis/heightmap.hpp"
#include "reefgen/heightfile.hpp"
#include "reefgen/files.hpp"
#include "reefgen/terrain/erosion.hpp"
#include "reefgen/terrain/layers.hpp"
#include "reefgen/terrain/rain.hpp"
#include "reefgen/terrain/realism.hpp"
#include "reefgen/version.hpp"

namespace reefgen {

namespace {

// Side limits of `reefgen erode`: those of inference (constants.hpp).
constexpr int kMinErodeSide = kMinInferSidePx, kMaxErodeSide = kMaxSidePx;

struct ErodeArgs {
  std::string input, prefix, range, erosion_file;
  FinishFlags finish;
  gis::HeightmapUnits units;
  double sea_level_m = 0;
  double resistance = 0.3;
  std::optional<double> wind_from_deg;  // where the prevailing wind comes from, degrees clockwise from north
  uint64_t seed = 1;
  int threads = default_threads();
  bool png16 = false, r16 = false, preview = false;
};

void parse_range(const std::string& text, gis::HeightmapUnits& u) {
  if (text.empty()) return;
  char extra = 0;
  if (std::sscanf(text.c_str(), "%lf:%lf%c", &u.lo_m, &u.hi_m, &extra) != 2 || !std::isfinite(u.lo_m) ||
      !std::isfinite(u.hi_m) || !(u.hi_m > u.lo_m))
    throw Error("--range " + text + ": expected LO:HI in metres with HI > LO, e.g. --range -100:600");
}

void check_square(const cv::Mat1f& h, const std::string& file) {
  if (h.rows != h.cols)
    throw Error(file + ": " + std::to_string(h.cols) + "×" + std::to_string(h.rows) +
                " is not square; crop or pad it to N×N (gdal_translate -srcwin)");
  if (h.cols < kMinErodeSide || h.cols > kMaxErodeSide)
    throw Error(file + ": " + std::to_string(h.cols) + "² is outside " + std::to_string(kMinErodeSide) + "²…" +
                std::to_string(kMaxErodeSide) + "²; resample it (gdalwarp -ts)");
}

// The cells erode's equations are calibrated for, m: a 0.1 m lidar grid to a
// 1 km ocean-basin grid. Outside, the flow routing meets slopes it cannot
// order (1e-3 m) or erodes nothing (1e5 m).
constexpr double kMinErodeCellM = 0.1, kMaxErodeCellM = 1000;

void check_cell_size(double mpp, const std::string& input) {
  if (mpp >= kMinErodeCellM && mpp <= kMaxErodeCellM) return;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", mpp);
  throw Error(input + ": cells of " + buf + " m; erode takes 0.1 to 1000 m cells (give the right one with "
              "--metres-per-px M or --world-size M)");
}

nlohmann::json realism_json(const cv::Mat1f& h, double mpp) {
  return terrain::realism_stats(h, mpp);
}

// The wind blowing from `from_deg` (a compass bearing, clockwise from north,
// as weather reports give it) as the vector it blows towards, image axes
// (x east, y south): from the north (0°) it blows to +y.
cv::Vec2d wind_towards(double from_deg) {
  const double t = from_deg * CV_PI / 180;
  return {-std::sin(t), std::cos(t)};
}

int run_erode(const ErodeArgs& a0, const GlobalOptions& g) {
  ErodeArgs a = a0;
  parse_range(a.range, a.units);
  const OutputNames names = output_names(a.prefix);
  terrain::ErosionParams ep;
  if (!a.erosion_file.empty()) ep = terrain::erosion_params_from_json(read_json(a.erosion_file), a.erosion_file);
  const FinishFlags::Parsed fin = a.finish.parse();
  engines::PlannedOutputs planned = engines::planned_outputs(names.prefix, fin.bundles);
  planned.files.push_back(names.height);  // -o may name the height file itself
  engines::refuse_outputs_over_inputs({a.input}, planned);
  finish_interrupted_commits_around(a.input);
  gis::Heightmap in = gis::read_heightmap(a.input, a.units);
  check_square(in.height_m, a.input);
  check_cell_size(in.metres_per_px, a.input);
  note_bundle_sizes(fin, in.height_m.cols, g.quiet, "");
  ensure_writable_dir(names.prefix.parent_path());
  const double mpp = in.metres_per_px, world_m = mpp * in.height_m.cols;
  cv::Mat1f before = in.height_m - float(a.sea_level_m);
  if (!g.quiet) std::fprintf(stderr, "erode: %s, %d², %.3g m per pixel\n", a.input.c_str(), before.cols, mpp);
  // With a wind, the rain from it (docs/EROSION.md "Rain from the wind"):
  // the windward side's discharge is the larger.
  terrain::RainFields rain;
  if (a.wind_from_deg) rain = terrain::rain_for_erosion(before, world_m, wind_towards(*a.wind_from_deg), terrain::RainParams{});
  cv::Mat1f out = terrain::erode_island(before, cv::Mat1f(before.size(), float(a.resistance)), world_m, a.seed, ep,
                                        rain.runoff_rel);
  if (a.finish.ocean_floor_m < 0) terrain::deepen_flank(out, a.finish.ocean_floor_m, mpp);

  StagedOutputs staged;
  HeightFiles hf;
  hf.png16 = a.png16;
  hf.r16 = a.r16;
  hf.preview = a.preview;
  hf.exr_path = names.height;
  nlohmann::json side = {{"tool", "reefgen"},
                         {"version", kVersion},
                         {"kind", "eroded heightmap"},
                         {"input", {{"path", fs::absolute(a.input).string()}, {"format", in.format},
                                    {"sea_level_m", a.sea_level_m}}},
                         {"size_px", out.cols},
                         {"metres_per_pixel", mpp},
                         {"erosion", ep},
                         {"resistance", a.resistance},
                         {"seed", a.seed},
                         {"wind_from_deg", a.wind_from_deg ? nlohmann::json(*a.wind_from_deg) : nlohmann::json()},
                         {"ocean_floor_m", a.finish.ocean_floor_m < 0 ? nlohmann::json(a.finish.ocean_floor_m) : nlohmann::json()},
                         {"realism_before", realism_json(before, mpp)},
                         {"realism_after", realism_json(out, mpp)}};
  side.update(stage_height_files(staged, names.prefix, out, mpp, hf));
  std::optional<terrain::Layers> L;
  if (fin.need_layers || a.finish.geotiff || !fin.bundles.empty())
    L = terrain::compute_layers(out, before, cv::Mat1b(), mpp, fin.rules, a.threads);
  if (a.finish.layers) {
    terrain::add_layers_to_sidecar(side, terrain::stage_layer_files(staged, names.prefix.string(), *L, mpp, fin.rules, a.threads));
    if (!rain.mm_yr.empty()) {
      terrain::stage_rain_file(staged, names.prefix.string(), rain.mm_yr, mpp);
      side["files"]["rain"] = fs::path(names.prefix.string() + terrain::kRainFileSuffix).filename().string();
    }
  }
  if (a.finish.geotiff)
    side["geotiff"] = gis::stage_geotiff_files(staged, names.prefix.string(), out, &*L, mpp, fin.geo, a.threads);
  if (!fin.bundles.empty())
    side["bundles"] = engines::stage_bundles(staged, names.prefix, fin.bundles, {out, &*L, mpp, fin.geo}, a.threads);
  staged.write(names.prefix.string() + ".json", [&](const fs::path& t) { write_json_atomic(t, side); });  // last
  staged.commit();
  for (const auto& p : staged.finals()) std::printf("%s\n", p.c_str());
  return 0;
}

}  // namespace

Command add_erode_command(CLI::App& app, const GlobalOptions& g) {
  auto a = std::make_shared<ErodeArgs>();
  auto* sub = app.add_subcommand(
      "erode",
      "Erode a heightmap of yours with reefgen's stream-power erosion, at its own size (docs/EROSION.md)\n\n"
      "Examples:\n"
      "  reefgen erode dem.tif -o out/dem --layers --geotiff\n"
      "  reefgen erode dem.tif -o out/dem --for unity,unreal\n"
      "  reefgen erode island.height.exr -o out/again --layers\n"
      "  reefgen erode island.height.exr -o out/wet --wind-from 60 --layers   # trade winds from the ENE\n"
      "  reefgen erode terrain.png --range -120:900 --world-size 8000 -o out/t --png16\n"
      "  reefgen erode terrain.r16 --range 0:1024 --metres-per-px 2 --sea-level 40 -o out/t --r16\n");
  sub->add_option("heightmap", a->input, "Heightmap: .exr (metres), .tif (GeoTIFF), .png (16-bit) or .r16/.raw (16-bit LE, square)")
      ->required();
  sub->add_option("-o,--output", a->prefix, "Output prefix: PREFIX.height.exr, .json (and the files asked for); never the input")
      ->required();
  sub->add_option("--range", a->range, "LO:HI — the metres of 16-bit 0 and 65535 (PNG16, R16)");
  sub->add_option("--world-size", a->units.world_size_m, "Width of the map in metres (cell size = this / width)")
      ->check(finite_in(1e-3, 1e9));
  sub->add_option("--metres-per-px", a->units.metres_per_px, "Cell size in metres (default: the file's own)")
      ->check(finite_in(kMinErodeCellM, kMaxErodeCellM));
  sub->add_option("--sea-level", a->sea_level_m, "Height of the sea in the input's metres; land above it erodes")
      ->check(finite_in(-1e5, 1e5))->capture_default_str();
  sub->add_option("--resistance", a->resistance, "Rock resistance ρ everywhere, 0 (soft) … 1 (hard)")
      ->check(finite_in(0, 1))->capture_default_str();
  sub->add_option("--wind-from", a->wind_from_deg,
                  "DEG: the prevailing wind's compass bearing (where it comes from, clockwise from north; trade winds ~60): "
                  "rain from it (Smith & Barstad) erodes the windward side harder; with --layers also PREFIX.rain.exr")
      ->check(CLI::Range(0.0, 360.0));
  sub->add_option("--erosion", a->erosion_file, "FILE: JSON of erosion parameters (docs/EROSION.md) overriding the defaults");
  sub->add_option("--seed", a->seed, "Seed of the fractal detail the refinement adds")->check(seed_value())->capture_default_str();
  add_finish_flags(sub, a->finish);
  sub->add_flag("--png16", a->png16, "Also write PREFIX.height.png (16-bit, range in the sidecar)");
  sub->add_flag("--r16", a->r16, "Also write PREFIX.r16 (16-bit RAW, little-endian)");
  sub->add_flag("--preview", a->preview, "Also write PREFIX.preview.png (hill-shaded colours)");
  sub->add_option("--threads", a->threads, "Threads for the layers and files (default: all cores; same bytes whatever the count)")
      ->check(CLI::Range(1, 256));
  return {sub, [a, &g] { return run_erode(*a, g); }};
}

}  // namespace reefgen
