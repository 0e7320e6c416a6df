#include "reefgen/gis/geotiff.hpp"

#include <gdal.h>
#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_string.h>
#include <ogr_srs_api.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <mutex>
#include <vector>

#include "reefgen/error.hpp"
#include "reefgen/files.hpp"
#include "reefgen/terrain/layers.hpp"
#include "reefgen/version.hpp"

namespace reefgen::gis {

namespace {

void init_gdal() {
  static std::once_flag once;
  std::call_once(once, [] {
    GDALAllRegister();
    // GDAL's messages become our one-line errors; nothing on stderr by itself.
    CPLSetErrorHandler(CPLQuietErrorHandler);
  });
}

std::string gdal_message() {
  const char* m = CPLGetLastErrorMsg();
  return (m && *m) ? m : "GDAL gave no reason";
}

struct Origin {
  double x, y;
};
Origin origin_of(const GeoReference& geo, int width, int height, double mpp) {
  return {std::isnan(geo.origin_x) ? -0.5 * width * mpp : geo.origin_x,
          std::isnan(geo.origin_y) ? 0.5 * height * mpp : geo.origin_y};
}

}  // namespace

std::string crs_wkt(const std::string& crs) {
  OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
  char* wkt = nullptr;
  const bool ok = OSRSetFromUserInput(srs, crs.c_str()) == OGRERR_NONE && OSRExportToWkt(srs, &wkt) == OGRERR_NONE;
  std::string out = ok && wkt ? wkt : "";
  const bool degrees = ok && OSRIsGeographic(srs) != 0;
  CPLFree(wkt);
  OSRDestroySpatialReference(srs);
  if (out.empty()) throw Error("--crs " + crs + ": GDAL does not know this CRS; use e.g. EPSG:32706 (UTM 6S) or a WKT string");
  // reefgen's grids are in metres: a CRS in degrees would label metres as degrees.
  if (degrees)
    throw Error("--crs " + crs + ": a geographic CRS (degrees); reefgen's grids are in metres: use a projected CRS, "
                "e.g. EPSG:32706 (UTM 6S)");
  return out;
}

void check_crs(const std::string& crs) {
  init_gdal();
  if (!crs.empty()) (void)crs_wkt(crs);
}

nlohmann::json geo_json(const GeoReference& geo, int width, int height, double mpp) {
  const Origin o = origin_of(geo, width, height, mpp);
  return {{"crs", geo.crs.empty() ? "none: a local metric grid (metres), the canvas centred on (0, 0); --crs and --origin place it" : geo.crs},
          {"origin_top_left", {o.x, o.y}},
          {"pixel_size_m", mpp},
          {"nodata", "none: every pixel holds a value"},
          {"north_up", true}};
}

namespace {
// Why a GeoTIFF could not be written: a full disk named as such (libtiff
// reports it as "TIFFRewriteDirectory: Error fetching directory count"),
// else GDAL's own message.
std::string write_failure(const std::filesystem::path& path, size_t raw_bytes) {
  std::error_code ec;
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  const std::filesystem::space_info sp = std::filesystem::space(folder, ec);
  // The file is compressed: less room than a tenth of its raw pixels (or
  // than 1 MiB) left after a failed write is a full disk.
  if (!ec && sp.available < std::max<uintmax_t>(raw_bytes / 10, uintmax_t(1) << 20))
    return "the disk is full (" + std::to_string(sp.available / 1024) + " KiB free in " + folder.string() +
           "); free some space or write to another folder";
  return gdal_message();
}
}  // namespace

void write_geotiff(const std::filesystem::path& path, const cv::Mat1f& band, double mpp, const GeoReference& geo,
                   const std::string& units, const std::string& description,
                   const std::map<std::string, std::string>& metadata) {
  init_gdal();
  const std::string wkt = geo.crs.empty() ? "" : crs_wkt(geo.crs);
  GDALDriverH drv = GDALGetDriverByName("GTiff");
  if (!drv) throw Error("cannot write " + path.string() + ": this GDAL has no GTiff driver");
  char** opts = nullptr;
  opts = CSLSetNameValue(opts, "COMPRESS", "DEFLATE");
  opts = CSLSetNameValue(opts, "PREDICTOR", "3");  // floating-point predictor
  opts = CSLSetNameValue(opts, "TILED", "YES");
  opts = CSLSetNameValue(opts, "BIGTIFF", "IF_SAFER");
  CPLErrorReset();
  GDALDatasetH ds = GDALCreate(drv, path.c_str(), band.cols, band.rows, 1, GDT_Float32, opts);
  CSLDestroy(opts);
  if (!ds) throw Error("cannot write " + path.string() + ": " + gdal_message());
  const Origin o = origin_of(geo, band.cols, band.rows, mpp);
  double gt[6] = {o.x, mpp, 0, o.y, 0, -mpp};
  bool ok = GDALSetGeoTransform(ds, gt) == CE_None;
  if (!wkt.empty()) ok = ok && GDALSetProjection(ds, wkt.c_str()) == CE_None;
  for (const auto& [k, v] : metadata) ok = ok && GDALSetMetadataItem(ds, k.c_str(), v.c_str(), nullptr) == CE_None;
  GDALRasterBandH b = GDALGetRasterBand(ds, 1);
  GDALSetDescription(b, description.c_str());
  ok = ok && GDALSetRasterUnitType(b, units.c_str()) == CE_None;
  const cv::Mat1f c = band.isContinuous() ? band : band.clone();
  ok = ok && GDALRasterIO(b, GF_Write, 0, 0, c.cols, c.rows, const_cast<float*>(c.ptr<float>()), c.cols, c.rows,
                          GDT_Float32, 0, 0) == CE_None;
  // Closing flushes: a full disk shows here (GDAL 3.6's GDALClose returns
  // nothing; the error state says it).
  CPLErrorReset();
  GDALClose(ds);
  ok = ok && CPLGetLastErrorType() < CE_Failure;
  if (!ok) throw Error("cannot write " + path.string() + ": " + write_failure(path, c.total() * sizeof(float)));
}

namespace {

// gdalwarp arguments that turn a W×H geographic raster with geotransform
// `gt` into a square grid in metres: the UTM zone of its centre (EPSG
// 326zz north, 327zz south), the largest square inside the projected
// footprint (no pixel outside the source, so no filled corners), max(W, H)
// pixels a side. "" where UTM does not reach (beyond 84° N / 80° S) or PROJ
// cannot convert the CRS.
std::string metric_warp_args(const std::string& wkt, const double gt[6], int W, int H) {
  const double lon = gt[0] + gt[1] * W / 2, lat = gt[3] + gt[5] * H / 2;
  if (!(lon >= -180 && lon <= 180 && lat >= -80 && lat <= 84)) return "";
  const int zone = std::clamp(int(std::floor((lon + 180) / 6)) + 1, 1, 60);
  const int epsg = (lat >= 0 ? 32600 : 32700) + zone;
  OGRSpatialReferenceH src = OSRNewSpatialReference(wkt.c_str()), dst = OSRNewSpatialReference(nullptr);
  std::string args;
  if (src && dst && OSRImportFromEPSG(dst, epsg) == OGRERR_NONE) {
    OSRSetAxisMappingStrategy(src, OAMS_TRADITIONAL_GIS_ORDER);
    OSRSetAxisMappingStrategy(dst, OAMS_TRADITIONAL_GIS_ORDER);
    if (OGRCoordinateTransformationH ct = OCTNewCoordinateTransformation(src, dst)) {
      // Corners: top-left, top-right, bottom-left, bottom-right.
      double x[4] = {gt[0], gt[0] + gt[1] * W, gt[0], gt[0] + gt[1] * W};
      double y[4] = {gt[3], gt[3], gt[3] + gt[5] * H, gt[3] + gt[5] * H};
      if (OCTTransform(ct, 4, x, y, nullptr)) {
        const double x0 = std::max(x[0], x[2]), x1 = std::min(x[1], x[3]);
        const double y0 = std::max(y[2], y[3]), y1 = std::min(y[0], y[1]);
        // A whole number of millimetres per cell and corners on millimetres:
        // the extent printed is exactly N cells of one size both ways.
        const int n = std::max(W, H);
        const double cell = std::floor(std::min(x1 - x0, y1 - y0) / n * 1000) / 1000;
        const double left = std::round(((x0 + x1) / 2 - cell * n / 2) * 1000) / 1000;
        const double bottom = std::round(((y0 + y1) / 2 - cell * n / 2) * 1000) / 1000;
        if (cell > 0) {
          char buf[256];
          std::snprintf(buf, sizeof buf, "-t_srs EPSG:%d -te %.3f %.3f %.3f %.3f -ts %d %d -r bilinear", epsg, left,
                        bottom, left + cell * n, bottom + cell * n, n, n);
          args = buf;
        }
      }
      OCTDestroyCoordinateTransformation(ct);
    }
  }
  if (src) OSRDestroySpatialReference(src);
  if (dst) OSRDestroySpatialReference(dst);
  return args;
}

}  // namespace

GeoRaster read_geotiff(const std::filesystem::path& path, int max_side) {
  init_gdal();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error("cannot read " + path.string() + ": no such file");
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error("cannot read " + path.string() + ": not a regular file (a folder, a FIFO or a device)");
  CPLErrorReset();
  GDALDatasetH ds = GDALOpen(path.c_str(), GA_ReadOnly);
  if (!ds) throw Error("cannot read " + path.string() + ": " + gdal_message());
  GeoRaster r;
  const int W = GDALGetRasterXSize(ds), H = GDALGetRasterYSize(ds);
  double gt[6];
  const bool has_gt = GDALGetGeoTransform(ds, gt) == CE_None && gt[2] == 0 && gt[4] == 0;
  if (has_gt) {
    r.metres_per_px = std::abs(gt[1]);
    // Within a millionth: a grid GDAL made from a printed extent differs by rounding.
    r.square_pixels = std::abs(std::abs(gt[1]) - std::abs(gt[5])) <= 1e-6 * std::abs(gt[1]);
    r.south_up = gt[5] > 0;
  }
  if (const char* p = GDALGetProjectionRef(ds)) r.crs_wkt = p;
  if (!r.crs_wkt.empty()) {
    OGRSpatialReferenceH srs = OSRNewSpatialReference(r.crs_wkt.c_str());
    if (srs) {
      r.geographic = OSRIsGeographic(srs) != 0;
      OSRDestroySpatialReference(srs);
    }
  }
  if (r.geographic && has_gt && !r.south_up) r.metric_warp_args = metric_warp_args(r.crs_wkt, gt, W, H);
  if (W > max_side || H > max_side) {
    GDALClose(ds);
    throw Error(path.string() + ": " + std::to_string(W) + "×" + std::to_string(H) + " pixels; at most " +
                std::to_string(max_side) + " a side here (resample it first: gdalwarp -ts)");
  }
  GDALRasterBandH b = GDALGetRasterCount(ds) > 0 ? GDALGetRasterBand(ds, 1) : nullptr;
  if (!b || W <= 0 || H <= 0 || int64_t(W) * H > int64_t(1) << 28) {
    GDALClose(ds);
    throw Error("cannot read " + path.string() + ": no band, or larger than 16384² pixels");
  }
  r.band.create(H, W);
  const bool ok = GDALRasterIO(b, GF_Read, 0, 0, W, H, r.band.ptr<float>(), W, H, GDT_Float32, 0, 0) == CE_None;
  int has_nodata = 0;
  const double nodata = GDALGetRasterNoDataValue(b, &has_nodata);
  GDALClose(ds);
  if (!ok) throw Error("cannot read " + path.string() + ": " + gdal_message());
  if (!cv::checkRange(r.band)) throw Error(path.string() + ": the band holds NaN or infinite values; fill the holes first (gdal_fillnodata.py)");
  if (has_nodata && cv::countNonZero(r.band == float(nodata)) > 0)
    throw Error(path.string() + ": the band has no-data pixels; fill them first (gdal_fillnodata.py)");
  return r;
}

}  // namespace reefgen::gis

namespace reefgen::gis {

const TiledBand& height_band() {
  static const TiledBand b{".height", "metre", "height above sea level, metres"};
  return b;
}

const std::vector<TiledBand>& layer_bands() {
  static const std::vector<TiledBand> bands = {
      {".flow", "square metre", "drainage area, square metres (0 at sea)"},
      {".slope", "degree", "slope, degrees"},
      {".wear", "metre", "metres removed by erosion"},
      {".deposit", "metre", "metres laid down (filled basins, settled sediment)"}};
  return bands;
}

std::vector<cv::Mat1f> layer_band_pixels(const terrain::Layers& L) {
  return {L.flow_area_m2, L.slope_deg, L.wear_m, L.deposit_m};
}

std::vector<std::string> geotiff_suffixes() {
  return {".height.tif", ".flow.tif", ".slope.tif", ".wear.tif", ".deposit.tif"};
}

void parse_origin(const std::string& text, GeoReference& geo) {
  double x = NAN, y = NAN;
  char extra = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf%c", &x, &y, &extra) != 2 || !std::isfinite(x) || !std::isfinite(y))
    throw Error("--origin " + text + ": expected X,Y in metres (the top-left corner in the CRS), e.g. 500000,8100000");
  geo.origin_x = x;
  geo.origin_y = y;
}

nlohmann::json stage_geotiff_files(StagedOutputs& staged, const std::string& prefix, const cv::Mat1f& height_m,
                                   const terrain::Layers* layers, double mpp, const GeoReference& geo, int threads) {
  check_crs(geo.crs);
  nlohmann::json files = nlohmann::json::object();
  const std::map<std::string, std::string> meta = {{"reefgen_version", kVersion}, {"sea_level_m", "0"}};
  std::vector<StagedOutputs::Job> jobs;
  auto put = [&](const TiledBand& b, const cv::Mat1f& band) {
    const std::string path = prefix + b.suffix + ".tif";
    jobs.emplace_back(path, [&band, &geo, &meta, mpp, &b](const std::filesystem::path& t) {
      write_geotiff(t, band, mpp, geo, b.units, b.description, meta);
    });
    files[b.suffix.substr(1)] = std::filesystem::path(path).filename().string();
  };
  put(height_band(), height_m);
  // Headers of the layers' maps, alive until the jobs have run.
  const std::vector<cv::Mat1f> pixels = layers ? layer_band_pixels(*layers) : std::vector<cv::Mat1f>{};
  for (size_t k = 0; k < pixels.size(); ++k) put(layer_bands()[k], pixels[k]);
  staged.write_all(jobs, threads);
  nlohmann::json j = geo_json(geo, height_m.cols, height_m.rows, mpp);
  j["files"] = files;
  return j;
}

}  // namespace reefgen::gis
