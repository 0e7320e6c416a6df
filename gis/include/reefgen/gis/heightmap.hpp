#pragma once
// A heightmap a user brings (`reefgen erode`), in the formats terrain tools
// write: OpenEXR in metres, GeoTIFF (through GDAL), 16-bit PNG or headerless
// 16-bit RAW (R16, little-endian, square) with the range they map to.
// Errors are one line naming the file and the missing fact (docs/GIS.md).
#include <cmath>
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

namespace reefgen::gis {

struct HeightmapUnits {
  double lo_m = NAN, hi_m = NAN;  // metres of 16-bit 0 and 65535 (--range LO:HI), needed by PNG16 and R16
  double metres_per_px = 0;       // cell size (--metres-per-px); 0 = the file's own or --world-size
  double world_size_m = 0;        // width of the map in metres (--world-size); 0 = the file's own
};

struct Heightmap {
  cv::Mat1f height_m;
  double metres_per_px = 0;
  std::string format;  // "exr", "geotiff", "png16", "r16"
};

// Reads by extension (.exr, .tif/.tiff, .png, .r16/.raw). The cell size: the
// flag, else --world-size / width, else the file's own (reefgen's EXR
// attribute, the GeoTIFF's geotransform); none of them is an error.
Heightmap read_heightmap(const std::filesystem::path& path, const HeightmapUnits& units);

}  // namespace reefgen::gis
