// reefgen realism FILE... : the realism statistics of docs/REALISM.md (pits,
// terraces, valleys) for height files, so users and tests measure the same thing.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <set>

#include <nlohmann/json.hpp>

#include "app.hpp"
#include "reefgen/image_io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/stats.hpp"
#include "reefgen/terrain/dissection.hpp"
#include "reefgen/terrain/landform.hpp"
#include "reefgen/terrain/flat_channels.hpp"
#include "reefgen/terrain/realism.hpp"
#include "reefgen/terrain/reef_stats.hpp"

namespace reefgen {

using terrain::realism_stats;
using terrain::RealismStats;

namespace {

struct RealismArgs {
  std::vector<std::string> files;
  double metres_per_px = 0;
  double world_size_m = 0;
  bool json = false;
  bool stream = false;
  bool reef = false;
  bool channels = false;
  bool dissection = false;
  bool drainage = false;
  std::optional<double> wind_from_deg;  // with --drainage: where the wind comes from, degrees clockwise from north
  double grid_period_px = 0;
  std::string sketch;
};

// The cell size: the flag, else the file's own attribute (reefgen writes
// reefgen:metres_per_pixel into every EXR), else --world-size / width.
double cell_size(const RealismArgs& a, const ExrAttributes& attrs, int width, const std::string& file) {
  if (a.metres_per_px > 0) return a.metres_per_px;
  if (a.world_size_m > 0) return a.world_size_m / width;
  if (const double v = exr_metres_per_px(attrs); v > 0) return v;
  throw Error(file + ": no metres per pixel in the file; pass --metres-per-px M or --world-size M");
}

// Past this many cells a file is read in bands of rows (a world larger than
// memory): 16385² read whole takes 9.6 GB.
constexpr int64_t kRealismWholeMaxCells = int64_t(16385) * 16385;

struct FileStats {
  RealismStats st;
  cv::Size size;
  double metres_per_px = 0;
  std::optional<terrain::SketchAgreement> agree;
  terrain::ReefStats reef;
  bool has_reef = false;
  std::optional<terrain::FlatChannelStats> channels;
  std::optional<terrain::DissectionStats> dissection;
  std::optional<terrain::LandformStats> drainage;
};

// The statistics (and the sketch's agreement) of `file`: whole, or a band of rows at a time.
FileStats stats_of(const std::string& file, const RealismArgs& a, const std::optional<DecodedSketch>& sketch) {
  ExrRowReader reader(file);
  FileStats r;
  r.size = reader.size();
  r.metres_per_px = cell_size(a, reader.attributes(), r.size.width, file);
  if (sketch) r.agree = terrain::SketchAgreement{};
  if (a.stream || int64_t(r.size.area()) > kRealismWholeMaxCells) {
    if (a.reef || a.channels || a.dissection || a.drainage)
      throw Error(file + ": --reef, --channels, --dissection and --drainage read the whole file; they cannot run with --stream or past 16385²");
    const terrain::StreamBands bands;
    for (int y0 = 0; y0 < r.size.height && sketch; y0 += bands.band_rows) {
      const int n = std::min(bands.band_rows, r.size.height - y0);
      terrain::add_sketch_agreement(*r.agree, reader.rows(y0, n), y0, r.size, sketch->label, sketch->subsidence);
    }
    r.st = terrain::realism_stats_streamed([&](int y0, int n) { return reader.rows(y0, n); }, r.size,
                                           r.metres_per_px, bands);
    return r;
  }
  const cv::Mat1f h = reader.rows(0, r.size.height);
  if (a.reef) r.reef = terrain::reef_stats(h, r.metres_per_px, a.grid_period_px), r.has_reef = true;
  if (a.channels) r.channels = terrain::flat_channel_stats(h, r.metres_per_px);
  if (a.dissection) r.dissection = terrain::dissection_stats(h, r.metres_per_px);
  if (a.drainage) r.drainage = terrain::landform_stats(h, r.metres_per_px, a.wind_from_deg.value_or(-1));
  if (sketch) r.agree = terrain::sketch_agreement(h, sketch->label, sketch->subsidence);
  r.st = realism_stats(h, r.metres_per_px);
  return r;
}

}  // namespace

// Long: one flag per line (the report's many switches), then a body that
// calls terrain/'s measures; the work is not here.
Command add_realism_command(CLI::App& app, const GlobalOptions&) {
  auto a = std::make_shared<RealismArgs>();
  auto* sub = app.add_subcommand("realism",
                                 "Realism statistics of height files: pits, terraces, valleys, seams (docs/REALISM.md)\n\n"
                                 "Examples:\n"
                                 "  reefgen realism out/atoll.height.exr\n"
                                 "  reefgen realism out/*.height.exr --json > stats.jsonl\n"
                                 "  reefgen realism dem.exr --metres-per-px 90\n"
                                 "  reefgen realism out/sea.height.exr --sketch sea.png   # painted land above the sea, abyss deep\n"
                                 "  reefgen realism out/atoll.height.exr --reef            # crest, reef flat, lagoon, passes, motu, floor\n"
                                 "  reefgen realism w/world.height.exr --reef --grid-period 8   # and the model grid at 1:1\n"
                                 "  reefgen realism w/world.height.exr --channels             # straight flat channels on land\n"
                                 "  reefgen realism out/old.height.exr --dissection            # drainage density, hypsometry (age)\n"
                                 "  reefgen realism out/yv.height.exr --drainage               # valley spacing, comb, wind, Hack\n"
                                 "  reefgen realism out/ws.height.exr --drainage --wind-from 270  # and windward valleys against leeward");
  sub->add_option("files", a->files, "Height files (OpenEXR, metres, sea level 0)")->required();
  sub->add_option("--metres-per-px", a->metres_per_px, "Cell size in metres (default: the file's own)")
      ->check(finite_in(1e-6, 1e6));
  sub->add_option("--world-size", a->world_size_m, "Canvas width in metres (cell size = this / width)")
      ->check(finite_in(1e-3, 1e9));
  sub->add_flag("--json", a->json, "One JSON object per file on stdout");
  sub->add_flag("--stream", a->stream,
                "Read the file a band of rows at a time (memory of a few bands; automatic past 16385²; "
                "docs/REALISM.md \"Streamed\")");
  sub->add_flag("--reef", a->reef,
                "Also the reef report: crest height and its share at sea level, reef-flat width, lagoon depth, "
                "passes, motu, the share of the canvas on a flat floor (docs/REALISM.md \"Reef\")");
  sub->add_option("--grid-period", a->grid_period_px,
                  "With --reef: the model grid's period in pixels (output side / 256) whose Fourier amplitude "
                  "on underwater slopes is reported")
      ->check(finite_in(2, 4096));
  sub->add_flag("--channels", a->channels,
                "Also the straight flat channels on land: components of land cells with slope < 0.5 %, at least "
                "25 px long and 5x longer than wide, inland (per 1000 km2 of land) and along the coast apart "
                "(docs/REALISM.md)");
  sub->add_flag("--dissection", a->dissection,
                "Also how far the island is dissected (its age, docs/REALISM.md \"Age and dissection\"): drainage "
                "density (km of valley channel per km2 of land) and hypsometry (land above half the peak, mean "
                "height / peak)");
  sub->add_flag("--drainage", a->drainage,
                "Also how the valleys are organised (docs/REALISM.md \"Drainage organisation\"): the spacing of "
                "valleys on circles round the summit (coefficient of variation), the angular spectrum's peak over "
                "its median (a comb), the dissection's variation between sectors (the wind), Hack's exponent, "
                "valleys per coastal basin and the valley depth's 90th percentile");
  sub->add_option("--wind-from", a->wind_from_deg,
                  "DEG: with --drainage, where the prevailing wind comes from (compass bearing, clockwise from "
                  "north): also the windward half's median valley depth over the leeward half's")
      ->check(CLI::Range(0.0, 360.0));
  sub->add_option("--sketch", a->sketch,
                  "The sketch the heights were drawn from: also the painted land above the sea and the painted "
                  "bright abyss below -20 m (any resolution over the same ground)");
  return {sub, [a] {
            std::optional<DecodedSketch> sketch;
            if (!a->sketch.empty()) {
              if (!fs::is_regular_file(a->sketch)) throw Error(a->sketch + ": no such sketch file");
              finish_interrupted_commits_around(a->sketch);
              sketch = read_sketch(a->sketch);
            }
            if (!a->json)
              std::printf("%-40s %7s %9s %9s %9s %9s %8s %10s %10s\n", "file", "size", "land", "max_m", "pits", "terraces",
                          "valleys", "seams_rows", "seams_cols");
            // Each folder swept once: `realism out/*.height.exr` over a dataset names thousands of files in one.
            std::set<fs::path> swept;
            for (const auto& f : a->files) {
              if (swept.insert(fs::absolute(f).parent_path()).second) finish_interrupted_commits_around(f);
              if (!fs::is_regular_file(f)) throw Error(f + ": no such file (expected an OpenEXR height file)");
              FileStats r;
              try {
                r = stats_of(f, *a, sketch);
              } catch (const Error& e) {
                // The statistics' own errors do not name the file; the reader's do.
                const std::string what = e.what();
                throw Error(what.find(f) == std::string::npos ? f + ": " + what : what);
              }
              const RealismStats& st = r.st;
              const cv::Size size = r.size;
              const double mpp = r.metres_per_px;
              const auto& agree = r.agree;
              const double land = double(st.land_cells) / double(size.area());
              if (a->json) {
                nlohmann::json j = st;
                j.update({{"file", f}, {"size_px", {size.width, size.height}}, {"metres_per_px", mpp}, {"land_share", land}});
                if (r.has_reef) {
                  const auto& e = r.reef;
                  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
                  j["reef"] = {{"rays_with_reef", e.rays_with_reef}, {"crest_median_m", num(e.crest_median_m)},
                               {"crest_at_sea", e.crest_at_sea},     {"reef_flat_width_m", num(e.reef_flat_width_m)},
                               {"lagoon_median_m", num(e.lagoon_median_m)}, {"lagoon_min_m", num(e.lagoon_min_m)},
                               {"passes", e.passes},                 {"motu", e.motu},
                               {"motu_widths_m", e.motu_widths_m},   {"flat_floor_share", e.flat_floor_share},
                               {"grid_amplitude_m", num(e.grid_amplitude_m)}, {"grid_ring_ratio", num(e.grid_ring_ratio)}};
                }
                if (r.channels)
                  j["straight_flat_channels"] = {{"count", r.channels->channels},
                                                 {"coastal", r.channels->coastal},
                                                 {"per_1000_km2_land", r.channels->per_1000_km2},
                                                 {"land_km2", r.channels->land_km2},
                                                 {"longest_px", r.channels->longest_px}};
                if (r.dissection)
                  j["dissection"] = {{"drainage_density_per_km", r.dissection->drainage_density_per_km},
                                     {"channel_threshold_m2", r.dissection->channel_threshold_m2},
                                     {"channel_exponent", r.dissection->channel_exponent},
                                     {"valley_density_per_km", r.dissection->valley_density_per_km},
                                     {"land_above_half_peak", r.dissection->land_above_half_peak},
                                     {"hypsometric_integral", r.dissection->hypsometric_integral},
                                     {"land_km2", r.dissection->land_km2}};
                if (r.drainage)
                  j["drainage"] = {{"spacing_cv", r.drainage->spacing_cv},
                                   {"spectrum_peak_ratio", r.drainage->spectrum_peak_ratio},
                                   {"sector_cv", r.drainage->sector_cv},
                                   {"hack_exponent", r.drainage->hack_exponent},
                                   {"valleys_per_basin", r.drainage->valleys_per_basin},
                                   {"valleys_on_circles", r.drainage->valleys_on_circles},
                                   {"valley_depth_p90_m", r.drainage->valley_depth_p90_m},
                                   {"grid_cell_m", r.drainage->cell_m}};
                if (r.drainage && a->wind_from_deg) j["drainage"]["windward_depth_ratio"] = r.drainage->windward_depth_ratio;
                if (agree) {
                  j["painted_land_above_sea"] = agree->land_above_sea;
                  j["painted_abyss_below_20m"] = agree->abyss_below_bar;
                }
                std::printf("%s\n", j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
              } else {
                std::printf("%-40s %4dx%-4d %8.1f%% %9.1f %8.2f%% %8.2f%% %8.3f %10.2f %10.2f\n", f.c_str(), size.width, size.height,
                            100 * land, st.max_height_m, 100 * st.pits, 100 * st.terraces, st.valleys, st.seams_rows,
                            st.seams_cols);
                if (st.land_cells > 0 && st.flank_cells == 0)
                  std::printf("%-40s no flank: the highest land is %.1f m (< %.0f m: motu, sand cays), so terraces, valleys and "
                              "seams are not judged (0; docs/REALISM.md)\n",
                              "", st.max_height_m, double(terrain::kFlankMinPeakM));
                if (r.has_reef) {
                  const auto& e = r.reef;
                  std::printf("%-40s reef: crest median %.2f m, at sea level (>= -1 m) on %.1f%% of %d rays; reef flat %.0f m; "
                              "lagoon median %.1f m, deepest %.1f m; passes %d; motu %d (median width %.0f m); "
                              "flat floor %.2f%%\n",
                              "", e.crest_median_m, 100 * e.crest_at_sea, e.rays_with_reef, e.reef_flat_width_m,
                              e.lagoon_median_m, e.lagoon_min_m, e.passes, e.motu, median(e.motu_widths_m),
                              100 * e.flat_floor_share);
                  if (a->grid_period_px > 0)
                    std::printf("%-40s model grid (%.0f px): %.4f m, %.2fx its ring's median\n", "", a->grid_period_px,
                                e.grid_amplitude_m, e.grid_ring_ratio);
                }
                if (r.channels)
                  std::printf("%-40s straight flat channels: %lld inland (%.2f per 1000 km2 of %.1f km2 land; longest %.0f px), "
                              "%lld flat strips along the coast\n",
                              "", (long long)r.channels->channels, r.channels->per_1000_km2, r.channels->land_km2,
                              r.channels->longest_px, (long long)r.channels->coastal);
                if (r.dissection)
                  std::printf("%-40s dissection: drainage density %.2f km/km2 (channels from %.0f m2, the slope-area "
                              "break; valleys from 0.1 km2 %.2f km/km2), land above half the peak %.1f%%, "
                              "hypsometric integral %.3f (%.1f km2 land)\n",
                              "", r.dissection->drainage_density_per_km, r.dissection->channel_threshold_m2,
                              r.dissection->valley_density_per_km, 100 * r.dissection->land_above_half_peak,
                              r.dissection->hypsometric_integral, r.dissection->land_km2);
                if (r.drainage)
                  std::printf("%-40s drainage: valley spacing CV %.2f (%d valleys on 3 circles), angular spectrum peak "
                              "%.1fx its median, sector dissection CV %.2f, Hack's exponent %.2f, %.2f valleys per "
                              "coastal basin, valley depth p90 %.1f m (read on %.0f m cells)\n",
                              "", r.drainage->spacing_cv, r.drainage->valleys_on_circles, r.drainage->spectrum_peak_ratio,
                              r.drainage->sector_cv, r.drainage->hack_exponent, r.drainage->valleys_per_basin,
                              r.drainage->valley_depth_p90_m, r.drainage->cell_m);
                if (r.drainage && a->wind_from_deg)
                  std::printf("%-40s wind from %.0f deg: windward valleys %.2fx as deep as leeward ones (medians)\n", "",
                              *a->wind_from_deg, r.drainage->windward_depth_ratio);
                if (agree)
                  std::printf("%-40s painted land above sea %.2f%% (%lld cells), bright abyss below -20 m %.2f%% (%lld cells)\n",
                              "", 100 * agree->land_above_sea, (long long)agree->land_cells, 100 * agree->abyss_below_bar,
                              (long long)agree->abyss_cells);
              }
            }
            return 0;
          }};
}

}  // namespace reefgen
