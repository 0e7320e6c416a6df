// gis/: GeoTIFF through libgdal and the heightmaps `reefgen erode` reads.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include <gdal.h>
#include <opencv2/core.hpp>

#include "reefgen/gis/geotiff.hpp"
#include "reefgen/gis/heightmap.hpp"
#include "reefgen/files.hpp"
#include "test_util.hpp"

using namespace reefgen;
using namespace reefgen::gis;

TEST(GeoTiff, RoundTripsHeightsPixelSizeAndCrs) {
  const auto d = test::temp_dir("gis_rt");
  cv::Mat1f h(40, 40);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x) h(y, x) = -120.5f + 3.25f * x + 0.125f * y * y;  // row 0 north
  GeoReference geo;
  geo.crs = "EPSG:32706";
  geo.origin_x = 500000;
  geo.origin_y = 8100000;
  write_geotiff(d / "h.tif", h, 7.5, geo, "metre", "height");
  const GeoRaster r = read_geotiff(d / "h.tif");
  EXPECT_EQ(cv::norm(r.band, h, cv::NORM_INF), 0.0);  // float32 kept exactly
  EXPECT_DOUBLE_EQ(r.metres_per_px, 7.5);
  EXPECT_NE(r.crs_wkt.find("32706"), std::string::npos);
  // Through read_heightmap: the geotransform gives the cell size.
  const Heightmap m = read_heightmap(d / "h.tif", {});
  EXPECT_EQ(m.format, "geotiff");
  EXPECT_DOUBLE_EQ(m.metres_per_px, 7.5);
}

TEST(GeoTiff, RefusesWhatItCannotPlace) {
  const auto d = test::temp_dir("gis_bad");
  GeoReference geo;
  geo.crs = "EPSG:999999";
  test::expect_error_naming([&] { write_geotiff(d / "x.tif", cv::Mat1f(4, 4, 1.f), 1.0, geo, "metre", "h"); }, "EPSG:999999");
  test::expect_error_naming([&] { read_geotiff(d / "missing.tif"); }, "missing.tif");
  write_text_atomic(d / "junk.tif", "not a tiff");
  test::expect_error_naming([&] { read_geotiff(d / "junk.tif"); }, "junk.tif");
  test::expect_error_naming([&] { parse_origin("12;34", geo); }, "--origin");
}

TEST(Heightmap, RawIsLittleEndianRowZeroFirst) {
  const auto d = test::temp_dir("gis_raw");
  // 2×2: values 0, 1, 256, 65535 in file order.
  const std::string bytes("\x00\x00\x01\x00\x00\x01\xff\xff", 8);
  write_file_atomic(d / "a.r16", bytes.data(), bytes.size());
  HeightmapUnits u;
  u.lo_m = -100;
  u.hi_m = 555.35;
  u.world_size_m = 20;
  const Heightmap m = read_heightmap(d / "a.r16", u);
  ASSERT_EQ(m.height_m.size(), cv::Size(2, 2));
  const double s = (u.hi_m - u.lo_m) / 65535.0;
  EXPECT_NEAR(m.height_m(0, 0), -100.0, 1e-4);
  EXPECT_NEAR(m.height_m(0, 1), -100.0 + s, 1e-4);
  EXPECT_NEAR(m.height_m(1, 0), -100.0 + 256 * s, 1e-4);
  EXPECT_NEAR(m.height_m(1, 1), 555.35, 1e-3);
  EXPECT_DOUBLE_EQ(m.metres_per_px, 10.0);
  test::expect_error_naming([&] { read_heightmap(d / "a.r16", {}); }, "--range");
  write_file_atomic(d / "b.r16", bytes.data(), 6);
  test::expect_error_naming([&] { read_heightmap(d / "b.r16", u); }, "6 bytes");
  write_text_atomic(d / "c.xyz", "1");
  test::expect_error_naming([&] { read_heightmap(d / "c.xyz", u); }, "unknown heightmap format");
}

// A world's GeoTIFF tiles: they partition the field, each placed
// by its own geotransform, and GDAL opens the VRT mosaic as the whole field,
// bit for bit.
TEST(GeoTiff, TilesAndTheirMosaicAreTheWholeField) {
  const fs::path d = test::temp_dir("gis_tiles");
  cv::Mat1f h(230, 250);
  cv::randu(h, -100.f, 500.f);
  StagedOutputs staged;
  const GeoReference geo{"EPSG:32706", 500000.0, 8000000.0};
  const nlohmann::json j = stage_geotiff_tiles(staged, d / "w.gis", "w", h, 12.5, geo, 2, 100);
  staged.commit();
  EXPECT_EQ(j["tiles"].size(), 9u);  // 3 × 3 tiles of 84 × 77
  EXPECT_EQ(j["tile_px"], nlohmann::json({84, 77}));
  const GeoRaster mosaic = read_geotiff(d / "w.gis" / "w.height.vrt");
  ASSERT_EQ(mosaic.band.size(), h.size());
  EXPECT_EQ(cv::norm(mosaic.band, h, cv::NORM_INF), 0.0);
  EXPECT_DOUBLE_EQ(mosaic.metres_per_px, 12.5);
  EXPECT_NE(mosaic.crs_wkt.find("UTM zone 6S"), std::string::npos) << mosaic.crs_wkt;
  // GDAL names the mosaic's band and its unit as the tiles' (QGIS showed "Band 1").
  GDALAllRegister();
  GDALDatasetH vrt = GDALOpen((d / "w.gis" / "w.height.vrt").c_str(), GA_ReadOnly);
  ASSERT_NE(vrt, nullptr);
  GDALRasterBandH band = GDALGetRasterBand(vrt, 1);
  EXPECT_EQ(std::string(GDALGetDescription(band)), height_band().description);
  EXPECT_EQ(std::string(GDALGetRasterUnitType(band)), height_band().units);
  EXPECT_FALSE(height_band().description.empty());
  GDALClose(vrt);
  // The south-east tile: the remainder, where its geotransform says.
  const GeoRaster last = read_geotiff(d / "w.gis" / "w_x2_y2.height.tif");
  ASSERT_EQ(last.band.size(), cv::Size(250 - 168, 230 - 154));
  EXPECT_EQ(cv::norm(last.band, h(cv::Rect(168, 154, 82, 76)), cv::NORM_INF), 0.0);
}
