#include "reefgen/gis/heightmap.hpp"

#include <algorithm>
#include <cctype>

#include "reefgen/constants.hpp"
#include "reefgen/gis/geotiff.hpp"
#include "reefgen/heightfile.hpp"
#include "reefgen/io.hpp"

namespace reefgen::gis {

namespace {

std::string lower_extension(const std::filesystem::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e;
}

void need_range(const std::filesystem::path& p, const HeightmapUnits& u, const char* what) {
  if (std::isnan(u.lo_m) || std::isnan(u.hi_m))
    throw Error(p.string() + ": a " + what + " holds no units; pass --range LO:HI (the metres of 0 and 65535)");
}

cv::Mat1f read_r16(const std::filesystem::path& p, const HeightmapUnits& u) {
  need_range(p, u, "16-bit RAW");
  const std::string bytes = read_text(p, size_t(2) << 28);
  const size_t n = bytes.size() / 2;
  const int side = int(std::lround(std::sqrt(double(n))));
  if (bytes.size() % 2 != 0 || size_t(side) * size_t(side) != n || side < 2)
    throw Error(p.string() + ": " + std::to_string(bytes.size()) +
                " bytes is not a square 16-bit RAW (2·N² bytes, e.g. 8396802 for 2049²); check the file or export it square");
  cv::Mat1f h(side, side);
  const double scale = (u.hi_m - u.lo_m) / 65535.0;
  for (size_t i = 0; i < n; ++i) {
    const unsigned v = unsigned(uint8_t(bytes[2 * i])) | unsigned(uint8_t(bytes[2 * i + 1])) << 8;  // little-endian
    h(int(i / side), int(i % side)) = float(u.lo_m + scale * v);
  }
  return h;
}

}  // namespace

Heightmap read_heightmap(const std::filesystem::path& p, const HeightmapUnits& u) {
  std::error_code ec;
  if (!std::filesystem::exists(p, ec)) throw Error("cannot read " + p.string() + ": no such file");
  if (!std::filesystem::is_regular_file(p, ec))
    throw Error("cannot read " + p.string() + ": not a regular file (a folder, a FIFO or a device)");
  if (!std::isnan(u.lo_m) && !(u.hi_m > u.lo_m)) throw Error("--range LO:HI needs HI > LO");
  Heightmap m;
  double own_mpp = 0;
  const std::string ext = lower_extension(p);
  if (ext == ".exr") {
    ExrAttributes attrs;
    m.height_m = read_exr_height(p, &attrs, kMaxSidePx);
    own_mpp = exr_metres_per_px(attrs);
    m.format = "exr";
  } else if (ext == ".tif" || ext == ".tiff") {
    GeoRaster r = read_geotiff(p, kMaxSidePx);
    // Degrees read as metres made 0.00028 m cells: hours of erosion, nonsense out.
    if (r.geographic) {
      // The exact command where it can be worked out (UTM zone, a square grid erode takes).
      const std::filesystem::path out = p.parent_path() / (p.stem().string() + ".utm.tif");
      throw Error(p.string() + ": its CRS is geographic (degrees, e.g. EPSG:4326); reproject it to a square grid in "
                  "metres first: gdalwarp " +
                  (r.metric_warp_args.empty() ? std::string("-t_srs EPSG:326zz (the UTM zone of the place) -ts N N")
                                              : r.metric_warp_args) +
                  " " + p.string() + " " + out.string());
    }
    if (r.south_up)
      throw Error(p.string() + ": it is stored south-up (positive pixel height); make it north-up first: gdalwarp " +
                  p.string() + " north-up.tif");
    if (!r.square_pixels) throw Error(p.string() + ": its pixels are not square; resample it first (gdalwarp -tr)");
    m.height_m = std::move(r.band);
    own_mpp = r.metres_per_px;
    m.format = "geotiff";
  } else if (ext == ".png") {
    need_range(p, u, "16-bit PNG");
    m.height_m = read_png16(p, u.lo_m, u.hi_m, kMaxSidePx);
    m.format = "png16";
  } else if (ext == ".r16" || ext == ".raw") {
    m.height_m = read_r16(p, u);
    m.format = "r16";
  } else {
    throw Error(p.string() + ": unknown heightmap format; use .exr (metres), .tif (GeoTIFF), .png (16-bit) or .r16/.raw");
  }
  if (!cv::checkRange(m.height_m)) throw Error(p.string() + ": the heights hold NaN or infinite values");
  m.metres_per_px = u.metres_per_px > 0 ? u.metres_per_px : u.world_size_m > 0 ? u.world_size_m / m.height_m.cols : own_mpp;
  if (!(m.metres_per_px > 0))
    throw Error(p.string() + ": no cell size in the file; pass --world-size M (the map's width) or --metres-per-px M");
  return m;
}

}  // namespace reefgen::gis
