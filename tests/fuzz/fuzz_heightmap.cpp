// libFuzzer target: the heightmaps `reefgen erode` reads. The first byte
// picks the format (OpenEXR, GeoTIFF through GDAL, 16-bit PNG, R16), the
// rest is the file. read_heightmap must refuse in one reefgen::Error line
// or give finite heights of a bounded size; crashes, hangs, sanitizer
// reports, other exceptions and anything past erode's 8192² are findings.
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/files.hpp"
#include "reefgen/gis/heightmap.hpp"

namespace fs = std::filesystem;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const char* const kExtensions[] = {".exr", ".tif", ".png", ".r16"};
  const fs::path file =
      fs::temp_directory_path() / ("reefgen-fuzz-heightmap-" + std::to_string(::getpid()) + kExtensions[data[0] % 4]);
  std::FILE* f = std::fopen(file.c_str(), "wb");
  if (!f) std::abort();
  if (size > 1) std::fwrite(data + 1, 1, size - 1, f);
  std::fclose(f);
  reefgen::gis::HeightmapUnits units;
  units.lo_m = -100;
  units.hi_m = 600;
  // Half the inputs give the cell size, half rely on the file's own.
  if (data[0] & 4) units.world_size_m = 6000;
  try {
    const reefgen::gis::Heightmap m = reefgen::gis::read_heightmap(file, units);
    if (m.height_m.cols > reefgen::kMaxSidePx || m.height_m.rows > reefgen::kMaxSidePx) std::abort();
    if (!cv::checkRange(m.height_m) || !(m.metres_per_px > 0) || !std::isfinite(m.metres_per_px)) std::abort();
  } catch (const reefgen::Error&) {
  }
  std::error_code ec;
  fs::remove(file, ec);
  return 0;
}
