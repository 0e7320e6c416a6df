#include <algorithm>
#include <cstdio>
#include <utility>
#include <sstream>

#include "reefgen/error.hpp"
#include "reefgen/gis/geotiff.hpp"
#include "reefgen/files.hpp"

namespace reefgen::gis {

namespace {
std::string xml_escaped(const std::string& s) {
  std::string o;
  for (char c : s) o += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : c == '"' ? "&quot;" : std::string(1, c);
  return o;
}

std::string tile_name(const std::string& name, int i, int j, const std::string& suffix) {
  return name + "_x" + std::to_string(i) + "_y" + std::to_string(j) + suffix + ".tif";
}

// A VRT mosaic of one band's tiles, opened by GDAL as the whole field.
class Mosaic {
 public:
  Mosaic(cv::Size size, double ox, double oy, double mpp, const std::string& wkt, const TiledBand& b) {
    vrt_.precision(17);
    vrt_ << "<VRTDataset rasterXSize=\"" << size.width << "\" rasterYSize=\"" << size.height << "\">\n";
    if (!wkt.empty()) vrt_ << "  <SRS>" << xml_escaped(wkt) << "</SRS>\n";
    vrt_ << "  <GeoTransform>" << ox << ", " << mpp << ", 0, " << oy << ", 0, " << -mpp << "</GeoTransform>\n";
    vrt_ << "  <VRTRasterBand dataType=\"Float32\" band=\"1\">\n";
    // The tiles' band description, so GIS tools name the mosaic's band as the tiles' (not "Band 1").
    if (!b.description.empty()) vrt_ << "    <Description>" << xml_escaped(b.description) << "</Description>\n";
    if (!b.units.empty()) vrt_ << "    <UnitType>" << xml_escaped(b.units) << "</UnitType>\n";
  }
  void add(const std::string& file, const cv::Rect& r) {
    vrt_ << "    <SimpleSource>\n      <SourceFilename relativeToVRT=\"1\">" << xml_escaped(file) << "</SourceFilename>\n"
         << "      <SourceBand>1</SourceBand>\n"
         << "      <SrcRect xOff=\"0\" yOff=\"0\" xSize=\"" << r.width << "\" ySize=\"" << r.height << "\"/>\n"
         << "      <DstRect xOff=\"" << r.x << "\" yOff=\"" << r.y << "\" xSize=\"" << r.width << "\" ySize=\""
         << r.height << "\"/>\n    </SimpleSource>\n";
  }
  std::string text() const { return vrt_.str() + "  </VRTRasterBand>\n</VRTDataset>\n"; }

 private:
  std::ostringstream vrt_;
};
}  // namespace

cv::Rect TileGrid::rect(int i, int j) const {
  return cv::Rect(i * tw, j * th, std::min(tw, size.width - i * tw), std::min(th, size.height - j * th));
}

TileGrid tile_grid(cv::Size world, int tile_max_px) {
  if (tile_max_px < 1) throw Error("geotiff tiles: the tile side must be ≥ 1");
  if (world.empty()) throw Error("geotiff tiles: the world is empty");
  TileGrid g;
  g.size = world;
  g.nx = (world.width + tile_max_px - 1) / tile_max_px;
  g.ny = (world.height + tile_max_px - 1) / tile_max_px;
  g.tw = (world.width + g.nx - 1) / g.nx;
  g.th = (world.height + g.ny - 1) / g.ny;
  return g;
}

nlohmann::json stage_geotiff_band_tiles(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name,
                                        cv::Size world, double mpp, const GeoReference& geo,
                                        const std::vector<TiledBand>& bands, const TileBands& tile, int threads,
                                        int tile_max_px) {
  ensure_writable_dir(dir);
  const TileGrid g = tile_grid(world, tile_max_px);
  const double ox = std::isnan(geo.origin_x) ? -0.5 * world.width * mpp : geo.origin_x;
  const double oy = std::isnan(geo.origin_y) ? 0.5 * world.height * mpp : geo.origin_y;
  check_crs(geo.crs);  // GDAL set up, the CRS known
  const std::string wkt = geo.crs.empty() ? "" : crs_wkt(geo.crs);
  std::vector<Mosaic> mosaics;
  nlohmann::json files = nlohmann::json::object();
  for (const auto& b : bands) mosaics.emplace_back(world, ox, oy, mpp, wkt, b);
  // Written a few files at a time: as many as there are threads, or one tile's bands.
  std::vector<StagedOutputs::Job> jobs;
  const size_t batch = std::max<size_t>(size_t(std::max(1, threads)), bands.size());
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      const cv::Rect r = g.rect(i, j);
      const std::vector<cv::Mat1f> pixels = tile(r, i, j);
      if (pixels.size() != bands.size()) throw Error("internal: a world tile has the wrong number of bands");
      const GeoReference tile_geo{geo.crs, ox + r.x * mpp, oy - r.y * mpp};
      const std::string tile_id = std::to_string(i) + "," + std::to_string(j);
      for (size_t b = 0; b < bands.size(); ++b) {
        const std::string file = tile_name(name, i, j, bands[b].suffix);
        const cv::Mat1f band = pixels[b];
        const TiledBand info = bands[b];
        jobs.emplace_back(dir / file, [band, mpp, tile_geo, tile_id, info](const std::filesystem::path& t) {
          write_geotiff(t, band, mpp, tile_geo, info.units, info.description, {{"reefgen:tile", tile_id}});
        });
        files[bands[b].suffix.substr(1)].push_back(file);
        mosaics[b].add(file, r);
      }
      if (jobs.size() >= batch) staged.write_all(std::exchange(jobs, {}), threads);
    }
  staged.write_all(jobs, threads);
  nlohmann::json vrts = nlohmann::json::object();
  for (size_t b = 0; b < bands.size(); ++b) {
    const std::string vrt_name = name + bands[b].suffix + ".vrt", text = mosaics[b].text();
    staged.write(dir / vrt_name, [&](const std::filesystem::path& t) { write_text_atomic(t, text); });
    vrts[bands[b].suffix.substr(1)] = vrt_name;
  }
  return {{"tiles", files}, {"tiles_per_axis", {g.nx, g.ny}}, {"tile_px", {g.tw, g.th}}, {"mosaics", vrts},
          {"geo", geo_json(geo, world.width, world.height, mpp)}};
}

nlohmann::json stage_geotiff_tiles(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name,
                                   const cv::Mat1f& h, double mpp, const GeoReference& geo, int threads,
                                   int tile_max_px) {
  const std::vector<TiledBand> bands = {height_band()};
  // Views of the heights: the jobs copy headers, not pixels.
  nlohmann::json j = stage_geotiff_band_tiles(
      staged, dir, name, h.size(), mpp, geo, bands, [&](const cv::Rect& r, int, int) { return std::vector<cv::Mat1f>{h(r)}; },
      threads, tile_max_px);
  // The heights' own keys, as before the layers were tiled too.
  j["mosaic"] = j["mosaics"]["height"];
  j["tiles"] = nlohmann::json(j["tiles"]["height"]);
  return j;
}

}  // namespace reefgen::gis
