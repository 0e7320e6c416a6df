#include "reefgen/heightfile.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "reefgen/io.hpp"
#include "reefgen/mesh.hpp"
#include "reefgen/preview.hpp"
#include "reefgen/version.hpp"

namespace reefgen {

namespace {

void check_mesh(const cv::Mat1f& h, const MeshOptions& o) {
  if (h.rows < 2 || h.cols < 2) throw Error("mesh: height field must be at least 2x2");
  if (!(o.exaggeration > 0 && o.exaggeration <= 100)) throw Error("mesh: exaggeration must be in (0, 100]");
  if (!(o.metres_per_px > 0)) throw Error("mesh: metres per pixel must be > 0");
}

// Vertex (row r, column c): x right, y up (height), z towards the viewer
// (image row 0 is the far edge), centred on the canvas.
struct Grid {
  const cv::Mat1f& h;
  const MeshOptions& o;
  float x(int c) const { return float((c - (h.cols - 1) / 2.0) * o.metres_per_px); }
  float z(int r) const { return float((r - (h.rows - 1) / 2.0) * o.metres_per_px); }
  float y(int r, int c) const { return float(h(r, c) * o.exaggeration); }
};

}  // namespace

cv::Mat1w to_u16(const cv::Mat1f& h, double lo, double hi) {
  if (!(hi > lo)) throw Error("height range [" + std::to_string(lo) + ", " + std::to_string(hi) + "] is empty");
  cv::Mat1w out(h.size());
  const double k = 65535.0 / (hi - lo);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x)
      out(y, x) = uint16_t(std::lround(std::clamp((double(h(y, x)) - lo) * k, 0.0, 65535.0)));
  return out;
}

void write_png16(const fs::path& path, const cv::Mat1f& h, double lo, double hi) {
  write_png(path, to_u16(h, lo, hi));
}

cv::Mat1f read_png16(const fs::path& path, double lo, double hi, int max_side) {
  const cv::Mat m = read_image(path, cv::IMREAD_UNCHANGED, max_side);
  if (m.type() != CV_16UC1) throw Error(path.string() + ": not a 16-bit greyscale PNG");
  cv::Mat1f out;
  m.convertTo(out, CV_32F, (hi - lo) / 65535.0, lo);
  return out;
}

void write_r16(const fs::path& path, const cv::Mat1f& h, double lo, double hi) {
  const cv::Mat1w u = to_u16(h, lo, hi);
  std::string bytes(size_t(u.total()) * 2, '\0');
  size_t k = 0;
  for (int y = 0; y < u.rows; ++y)
    for (int x = 0; x < u.cols; ++x) {  // little-endian whatever the host
      bytes[k++] = char(u(y, x) & 0xff);
      bytes[k++] = char(u(y, x) >> 8);
    }
  write_file_atomic(path, bytes.data(), bytes.size());
}

namespace {
// Unity's terrains take square heightmaps of 2ⁿ + 1 samples, 33 … 4097.
bool unity_size(int w, int h) {
  if (w != h || w < 33 || w > 4097) return false;
  return ((w - 1) & (w - 2)) == 0;
}
}  // namespace

std::string r16_import_note(int w, int h, double lo, double hi, double mpp) {
  std::ostringstream s;
  // N samples span (N − 1) cells, as in Unreal and the meshes.
  s << "RAW import: " << w << "x" << h << ", 16-bit, byte order little-endian (Windows), 0 = " << lo
    << " m, 65535 = " << hi << " m; row 0 is north.\n";
  if (unity_size(w, h))
    s << "  Unity Terrain > Import Raw: Depth Bit 16, Width " << w << ", Height " << h
      << ", Byte Order Windows, Flip Vertically on (Unity's row 0 is south), Terrain Size x = z = " << mpp * (w - 1)
      << " m, y = " << (hi - lo) << " m; set the terrain's position y to " << lo << " m so sea level is at 0.\n";
  else
    s << "  Unity cannot import this file: its terrains take square 2^n+1 heightmaps (33 ... 4097); use --size "
         "1025, 2049 or 4097.\n";
  s
    << "  Unreal Landscape > Import from file (.r16): resolution " << w << "x" << h << ", Scale Z = "
    << (hi - lo) * 100.0 / 512.0 << " (% of 512 m), X = Y = " << mpp * 100.0
    << " (cm per vertex), Location Z = " << (lo + hi) / 2 * 100.0 << " cm.\n";
  return s.str();
}

HeightRange export_range(const cv::Mat1f& h) {
  if (!cv::checkRange(h, true)) throw Error("export: the height field holds NaN or infinity");  // minMaxLoc skips NaN
  double lo = 0, hi = 0;
  cv::minMaxLoc(h, &lo, &hi);
  HeightRange r{std::floor(lo), std::ceil(hi)};
  if (r.hi_m - r.lo_m < 1) r.hi_m = r.lo_m + 1;
  return r;
}

std::string engine_import_json(int w, int h, const HeightRange& r, double mpp) {
  const double span = r.hi_m - r.lo_m;
  const nlohmann::json j = {
      {"range_m", {r.lo_m, r.hi_m}},
      {"encoding", "linear: metres = lo + v/65535 * (hi - lo)"},
      {"unreal",
       {{"scale_z_percent", span * 100.0 / 512.0},  // Unreal maps 16 bits to 512 m at Z scale 100
        {"scale_xy_cm", mpp * 100.0},
        {"location_z_cm", (r.lo_m + r.hi_m) / 2 * 100.0},  // puts sea level (0 m) at world Z = 0
        {"resolution", {w, h}}}},
      {"unity", {{"terrain_height_m", span}, {"terrain_width_m", mpp * (w - 1)}, {"position_y_m", r.lo_m},
                 {"byte_order", "Windows (little-endian)"}, {"flip_vertically", true},
                 {"importable", unity_size(w, h)}, {"resolution", {w, h}}}},
      {"blender", {{"displace_strength_m", span}, {"displace_midlevel", -r.lo_m / span}}}};
  return j.dump();
}

Mesh grid_mesh(const cv::Mat1f& h, const MeshOptions& o) {
  check_mesh(h, o);
  const Grid g{h, o};
  Mesh m;
  m.positions.reserve(size_t(h.total()));
  m.normals.reserve(size_t(h.total()));
  for (int r = 0; r < h.rows; ++r)
    for (int c = 0; c < h.cols; ++c) {
      m.positions.emplace_back(g.x(c), g.y(r, c), g.z(r));
      // Normal from central differences of the surface y(x, z): smoother than
      // face averages on a regular grid.
      const int c0 = std::max(c - 1, 0), c1 = std::min(c + 1, h.cols - 1);
      const int r0 = std::max(r - 1, 0), r1 = std::min(r + 1, h.rows - 1);
      const double dydx = (g.y(r, c1) - g.y(r, c0)) / (g.x(c1) - g.x(c0));
      const double dydz = (g.y(r1, c) - g.y(r0, c)) / (g.z(r1) - g.z(r0));
      const double len = std::sqrt(dydx * dydx + 1 + dydz * dydz);
      m.normals.emplace_back(float(-dydx / len), float(1 / len), float(-dydz / len));
    }
  m.triangles.reserve(size_t(h.rows - 1) * size_t(h.cols - 1) * 2);
  for (int r = 0; r + 1 < h.rows; ++r)
    for (int c = 0; c + 1 < h.cols; ++c) {
      const uint32_t a = uint32_t(r * h.cols + c), b = a + 1, cc = a + uint32_t(h.cols), d = cc + 1;
      m.triangles.push_back({a, cc, b});  // counter-clockwise from above
      m.triangles.push_back({b, cc, d});
    }
  // Texture coordinates over the canvas: the preview (or any top-view map of
  // the same extent) drapes onto the mesh; pixel centres, like the vertices.
  m.uvs.resize(m.positions.size());
  for (int r = 0; r < h.rows; ++r)
    for (int c = 0; c < h.cols; ++c) m.uvs[size_t(r) * size_t(h.cols) + size_t(c)] = {(c + 0.5f) / h.cols, (r + 0.5f) / h.rows};
  return m;
}

void write_obj(const fs::path& path, const cv::Mat1f& h, const MeshOptions& o) {
  reefgen::write_obj(path, grid_mesh(h, o),
                     "reefgen height field: metres, +Y up, " + std::to_string(h.cols) + "x" + std::to_string(h.rows) +
                         " vertices, vertical exaggeration " + std::to_string(o.exaggeration));
}

void write_glb(const fs::path& path, const cv::Mat1f& h, const MeshOptions& o) {
  reefgen::write_glb(path, grid_mesh(h, o), "island");
}

namespace {
// A GDAL VRT that reads a 16-bit height file as metres: pixel size, the
// linear Offset/Scale (gdal_translate -unscale, QGIS and gdaldem -s honour
// them), the canvas centred on (0, 0) like the GeoTIFFs (docs/GIS.md).
std::string height_vrt(const std::string& file, bool raw, int w, int h, double lo, double hi, double mpp) {
  std::ostringstream s;
  s.precision(17);
  s << "<VRTDataset rasterXSize=\"" << w << "\" rasterYSize=\"" << h << "\">\n"
    << "  <GeoTransform>" << -0.5 * w * mpp << ", " << mpp << ", 0, " << 0.5 * h * mpp << ", 0, " << -mpp
    << "</GeoTransform>\n";
  if (raw) {
    s << "  <VRTRasterBand dataType=\"UInt16\" band=\"1\" subClass=\"VRTRawRasterBand\">\n"
      << "    <SourceFilename relativetoVRT=\"1\">" << file << "</SourceFilename>\n"
      << "    <ImageOffset>0</ImageOffset>\n    <PixelOffset>2</PixelOffset>\n"
      << "    <LineOffset>" << 2 * w << "</LineOffset>\n    <ByteOrder>LSB</ByteOrder>\n";
  } else {
    s << "  <VRTRasterBand dataType=\"UInt16\" band=\"1\">\n"
      << "    <SimpleSource>\n      <SourceFilename relativeToVRT=\"1\">" << file
      << "</SourceFilename>\n      <SourceBand>1</SourceBand>\n    </SimpleSource>\n";
  }
  s << "    <UnitType>metre</UnitType>\n    <Offset>" << lo << "</Offset>\n    <Scale>" << (hi - lo) / 65535.0
    << "</Scale>\n  </VRTRasterBand>\n</VRTDataset>\n";
  return s.str();
}
}  // namespace

nlohmann::json stage_height_files(StagedOutputs& staged, const std::filesystem::path& prefix,
                                  const cv::Mat1f& height_m, double metres_per_px, const HeightFiles& f) {
  const std::string pre = prefix.string();
  const HeightRange er = export_range(height_m);
  const double lo = er.lo_m, hi = er.hi_m;
  nlohmann::json side = {{"files", nlohmann::json::object()}};
  auto add = [&](const std::string& kind, const std::filesystem::path& p) { side["files"][kind] = p.filename().string(); };
  auto import_numbers = [&] {
    return nlohmann::json::parse(engine_import_json(height_m.cols, height_m.rows, er, metres_per_px));
  };
  if (f.exr) {
    const std::filesystem::path p = f.exr_path.empty() ? std::filesystem::path(pre + ".height.exr") : f.exr_path;
    std::map<std::string, std::string> attrs = f.exr_attributes;
    attrs["reefgen:version"] = kVersion;
    attrs["reefgen:metres_per_pixel"] = std::to_string(metres_per_px);
    staged.write(p, [&](const std::filesystem::path& t) { write_exr_height(t, height_m, attrs); });
    add("height_exr", p);
  }
  if (f.png16) {
    const std::filesystem::path p = pre + ".height.png";
    staged.write(p, [&](const std::filesystem::path& t) { write_png16(t, height_m, lo, hi); });
    add("height_png16", p);
    const std::string vrt = height_vrt(p.filename().string(), false, height_m.cols, height_m.rows, lo, hi, metres_per_px);
    staged.write(pre + ".height.png.vrt", [&](const std::filesystem::path& t) { write_text_atomic(t, vrt); });
    add("height_png16_vrt", pre + ".height.png.vrt");
    side["png16"] = {{"encoding", "linear: metres = lo + v/65535·(hi − lo)"}, {"lo_m", lo}, {"hi_m", hi},
                     {"import", import_numbers()}};
  }
  if (f.r16) {
    const std::filesystem::path p = pre + ".r16";
    staged.write(p, [&](const std::filesystem::path& t) { write_r16(t, height_m, lo, hi); });
    add("height_r16", p);
    const std::string vrt = height_vrt(p.filename().string(), true, height_m.cols, height_m.rows, lo, hi, metres_per_px);
    staged.write(pre + ".r16.vrt", [&](const std::filesystem::path& t) { write_text_atomic(t, vrt); });
    add("height_r16_vrt", pre + ".r16.vrt");
    side["r16"] = {{"width", height_m.cols}, {"height", height_m.rows}, {"byte_order", "little-endian"},
                   {"lo_m", lo}, {"hi_m", hi},
                   {"import_note", r16_import_note(height_m.cols, height_m.rows, lo, hi, metres_per_px)},
                   {"import", import_numbers()}};
  }
  if (!f.mesh.empty()) {
    if (f.mesh != "obj" && f.mesh != "glb") throw Error("mesh format '" + f.mesh + "': use obj or glb");
    const std::filesystem::path p = f.mesh_path.empty() ? std::filesystem::path(pre + "." + f.mesh) : f.mesh_path;
    const MeshOptions mo{metres_per_px, f.exaggeration};
    staged.write(p, [&](const std::filesystem::path& t) {
      if (f.mesh == "obj") write_obj(t, height_m, mo);
      else write_glb(t, height_m, mo);
    });
    add("mesh", p);
    side["mesh"] = {{"format", f.mesh}, {"up", "+Y"}, {"units", "metres"}, {"exaggeration", f.exaggeration}};
  }
  if (f.preview) {
    const std::filesystem::path p = pre + ".preview.png";
    PreviewOptions po;
    po.metres_per_px = metres_per_px;
    staged.write(p, [&](const std::filesystem::path& t) { write_png(t, render_preview(height_m, po)); });
    add("preview", p);
  }
  return side;
}

}  // namespace reefgen
