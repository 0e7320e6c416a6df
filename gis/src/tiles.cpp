#include <cstdio>
#include <sstream>

#include "reefgen/error.hpp"
#include "reefgen/gis/geotiff.hpp"
#include "reefgen/io.hpp"

namespace reefgen::gis {

namespace {
std::string xml_escaped(const std::string& s) {
  std::string o;
  for (char c : s) o += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : c == '"' ? "&quot;" : std::string(1, c);
  return o;
}

std::string tile_name(const std::string& name, int i, int j) {
  return name + "_x" + std::to_string(i) + "_y" + std::to_string(j) + ".height.tif";
}
}  // namespace

nlohmann::json stage_geotiff_tiles(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name,
                                   const cv::Mat1f& h, double mpp, const GeoReference& geo, int threads,
                                   int tile_max_px) {
  ensure_writable_dir(dir);
  std::vector<StagedOutputs::Job> jobs;
  const int W = h.cols, H = h.rows;
  if (tile_max_px < 1) throw Error("geotiff tiles: the tile side must be ≥ 1");
  const int nx = (W + tile_max_px - 1) / tile_max_px, ny = (H + tile_max_px - 1) / tile_max_px;
  const int tw = (W + nx - 1) / nx, th = (H + ny - 1) / ny;
  const double ox = std::isnan(geo.origin_x) ? -0.5 * W * mpp : geo.origin_x;
  const double oy = std::isnan(geo.origin_y) ? 0.5 * H * mpp : geo.origin_y;
  check_crs(geo.crs);  // GDAL set up, the CRS known
  const std::string wkt = geo.crs.empty() ? "" : crs_wkt(geo.crs);
  std::ostringstream vrt;
  vrt.precision(17);
  vrt << "<VRTDataset rasterXSize=\"" << W << "\" rasterYSize=\"" << H << "\">\n";
  if (!wkt.empty()) vrt << "  <SRS>" << xml_escaped(wkt) << "</SRS>\n";
  vrt << "  <GeoTransform>" << ox << ", " << mpp << ", 0, " << oy << ", 0, " << -mpp << "</GeoTransform>\n";
  vrt << "  <VRTRasterBand dataType=\"Float32\" band=\"1\">\n    <UnitType>metre</UnitType>\n";
  nlohmann::json files = nlohmann::json::array();
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const cv::Rect r(i * tw, j * th, std::min(tw, W - i * tw), std::min(th, H - j * th));
      const std::string file = tile_name(name, i, j);
      const GeoReference tile_geo{geo.crs, ox + r.x * mpp, oy - r.y * mpp};
      const cv::Mat1f band = h(r);  // a view: each job copies the header, not the pixels
      const std::string tile_id = std::to_string(i) + "," + std::to_string(j);
      jobs.emplace_back(dir / file, [band, mpp, tile_geo, tile_id](const std::filesystem::path& t) {
        write_geotiff(t, band, mpp, tile_geo, "metre", "height above sea level", {{"reefgen:tile", tile_id}});
      });
      files.push_back(file);
      vrt << "    <SimpleSource>\n      <SourceFilename relativeToVRT=\"1\">" << file << "</SourceFilename>\n"
          << "      <SourceBand>1</SourceBand>\n"
          << "      <SrcRect xOff=\"0\" yOff=\"0\" xSize=\"" << r.width << "\" ySize=\"" << r.height << "\"/>\n"
          << "      <DstRect xOff=\"" << r.x << "\" yOff=\"" << r.y << "\" xSize=\"" << r.width << "\" ySize=\""
          << r.height << "\"/>\n    </SimpleSource>\n";
    }
  vrt << "  </VRTRasterBand>\n</VRTDataset>\n";
  staged.write_all(jobs, threads);
  const std::string vrt_name = name + ".height.vrt";
  const std::string text = vrt.str();
  staged.write(dir / vrt_name, [&](const std::filesystem::path& t) { write_text_atomic(t, text); });
  return {{"tiles", files}, {"tiles_per_axis", {nx, ny}}, {"tile_px", {tw, th}}, {"mosaic", vrt_name},
          {"geo", geo_json(geo, W, H, mpp)}};
}

}  // namespace reefgen::gis
