#pragma once
// GeoTIFF through GDAL's own library (Debian's libgdal): float32 heights in
// metres and the float layers, with the pixel size in metres, an optional
// CRS and origin, and the units said in the file (docs/GIS.md). GIS tools
// (gdalinfo, gdaldem, gdal_contour, QGIS) read them unscaled. LibTorch-free.
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace reefgen::gis {

struct GeoReference {
  // Any CRS GDAL understands ("EPSG:32706", a WKT or PROJ string); empty =
  // a local metric grid with no CRS.
  std::string crs;
  // Map coordinates (CRS units, metres) of the top-left corner of the
  // top-left pixel; NaN = the canvas centred on (0, 0).
  double origin_x = NAN, origin_y = NAN;
};

// Writes `band` (float32, row 0 north) to `path` as a deflate-compressed,
// tiled GeoTIFF: pixel size metres_per_px, north up, `units` ("metre",
// "degree", "square metre") as the band's unit type, `description` as the
// band's description, every `metadata` pair as dataset metadata. No no-data
// value: every pixel holds a value. Throws reefgen::Error naming the path
// (and the CRS when GDAL does not know it). The path is written in place:
// callers stage it (StagedOutputs) for all-or-nothing output.
void write_geotiff(const std::filesystem::path& path, const cv::Mat1f& band, double metres_per_px,
                   const GeoReference& geo, const std::string& units, const std::string& description,
                   const std::map<std::string, std::string>& metadata = {});

struct GeoRaster {
  cv::Mat1f band;              // the first band, float32
  double metres_per_px = 0;    // from the geotransform (0 = none in the file)
  bool square_pixels = true;   // |pixel width| == |pixel height|
  std::string crs_wkt;         // "" = none
  bool geographic = false;     // the CRS is in degrees (e.g. EPSG:4326): the pixel size is not metres
  bool south_up = false;       // positive pixel height: row 0 is the south edge
  // For a geographic raster: the arguments of a gdalwarp that makes it a
  // square metre grid (its place's UTM zone, the largest square inside its
  // footprint, as many pixels a side as its longer side); "" when none
  // can be worked out (no geotransform, polar, a CRS PROJ cannot convert).
  std::string metric_warp_args;
};
// Reads a GeoTIFF (any GDAL raster, in fact) band 1 as float32. Refuses a
// missing file, a folder, a file GDAL cannot open, one wider or taller than
// max_side (before reading its pixels), and bands holding NaN or no-data
// pixels (one line naming the file and the fix).
GeoRaster read_geotiff(const std::filesystem::path& path, int max_side = 16384);

// What the sidecar says about a GeoTIFF written with `geo`.
nlohmann::json geo_json(const GeoReference& geo, int width, int height, double metres_per_px);

// Throws reefgen::Error unless GDAL knows `crs` (checked before any file is written).
void check_crs(const std::string& crs);
// `crs` (anything GDAL's SetFromUserInput takes) as WKT; throws reefgen::Error naming it.
std::string crs_wkt(const std::string& crs);

}  // namespace reefgen::gis

namespace reefgen {
class StagedOutputs;
namespace terrain {
struct Layers;
}
}  // namespace reefgen

namespace reefgen::gis {

// Stages PREFIX.height.tif (metres) and, with `layers`, PREFIX.flow.tif (m²),
// .slope.tif (degrees), .wear.tif and .deposit.tif (metres), all float32 on
// the same grid; returns the sidecar's "geotiff" object (files, CRS, origin,
// pixel size, no-data).
nlohmann::json stage_geotiff_files(StagedOutputs& staged, const std::string& prefix, const cv::Mat1f& height_m,
                                   const terrain::Layers* layers, double metres_per_px, const GeoReference& geo,
                                   int threads = 1);

// The suffixes stage_geotiff_files may write (for output-over-input checks).
std::vector<std::string> geotiff_suffixes();

// "X,Y" → origin (metres); throws reefgen::Error naming the flag.
void parse_origin(const std::string& text, GeoReference& geo);

}  // namespace reefgen::gis

namespace reefgen::gis {

// Past this side a world's GeoTIFF is written in tiles (docs/WORLDS.md): GIS
// tools and web tilers read tiles of a few thousand pixels at a time.
inline constexpr int kGeoTiffTileMaxPx = 4096;

// How a world is cut into GeoTIFF tiles: nx × ny tiles of tw × th pixels
// (the last row and column the remainder), tiles per axis ⌈side / max⌉.
struct TileGrid {
  int nx = 1, ny = 1, tw = 0, th = 0;
  cv::Size size;
  cv::Rect rect(int i, int j) const;  // tile (i east, j south) in the world
};
TileGrid tile_grid(cv::Size world, int tile_max_px = kGeoTiffTileMaxPx);

// One raster of a tiled world: files NAME_x{i}_y{j}<suffix>.tif and the
// mosaic NAME<suffix>.vrt, float32, `units` and `description` in each.
struct TiledBand {
  std::string suffix;  // ".height", ".flow", …
  std::string units, description;
};
// The height band and the four float layers' bands (flow, slope, wear,
// deposit), with the units and descriptions every GeoTIFF of them carries,
// whole or tiled; layer_band_pixels gives the layers' pixels in that order.
const TiledBand& height_band();
const std::vector<TiledBand>& layer_bands();
std::vector<cv::Mat1f> layer_band_pixels(const terrain::Layers& layers);

// The pixels of every band of tile (i, j), `rect` of the world, in the order of the bands.
using TileBands = std::function<std::vector<cv::Mat1f>(const cv::Rect& rect, int i, int j)>;

// Stages a world's bands as float32 GeoTIFF tiles in `dir` (the grid of
// tile_grid: i east, j south from the north-west tile, no overlap) and one
// VRT mosaic per band that GDAL opens as the whole field. Same pixel size,
// CRS and origin rules as write_geotiff. Tiles are made one at a time by
// `tile` (bounded memory) and written as they come. Returns the sidecar's
// object (files per band, tile size, mosaics).
nlohmann::json stage_geotiff_band_tiles(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name,
                                        cv::Size world, double metres_per_px, const GeoReference& geo,
                                        const std::vector<TiledBand>& bands, const TileBands& tile, int threads = 1,
                                        int tile_max_px = kGeoTiffTileMaxPx);

// The heights alone: NAME_x{i}_y{j}.height.tif and NAME.height.vrt.
nlohmann::json stage_geotiff_tiles(StagedOutputs& staged, const std::filesystem::path& dir, const std::string& name,
                                   const cv::Mat1f& height_m, double metres_per_px, const GeoReference& geo,
                                   int threads = 1, int tile_max_px = kGeoTiffTileMaxPx);

}  // namespace reefgen::gis
