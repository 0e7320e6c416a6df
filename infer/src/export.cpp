#include "reefgen/infer/export.hpp"

#include <cmath>
#include <cstring>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "reefgen/io.hpp"

namespace reefgen::infer {

namespace {

cv::Mat1w to_u16(const cv::Mat1f& h, double lo, double hi) {
  if (!(hi > lo)) throw Error("height range [" + std::to_string(lo) + ", " + std::to_string(hi) + "] is empty");
  cv::Mat1w out(h.size());
  const double k = 65535.0 / (hi - lo);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x)
      out(y, x) = uint16_t(std::lround(std::clamp((double(h(y, x)) - lo) * k, 0.0, 65535.0)));
  return out;
}

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

void write_png16(const fs::path& path, const cv::Mat1f& h, double lo, double hi) {
  write_png(path, to_u16(h, lo, hi));
}

cv::Mat1f read_png16(const fs::path& path, double lo, double hi) {
  const cv::Mat m = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (m.empty() || m.type() != CV_16UC1) throw Error(path.string() + ": not a 16-bit greyscale PNG");
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

std::string r16_import_note(int w, int h, double lo, double hi, double mpp) {
  std::ostringstream s;
  s << "RAW import: " << w << "x" << h << ", 16-bit, byte order little-endian (Windows), 0 = " << lo
    << " m, 65535 = " << hi << " m.\n"
    << "  Unity Terrain > Import Raw: Depth Bit 16, Width " << w << ", Height " << h
    << ", Byte Order Windows, Terrain Size x = z = " << mpp * w << " m, y = " << (hi - lo)
    << " m; set the terrain's position y to " << lo << " m so sea level is at 0.\n"
    << "  Unreal Landscape > Import from file (.r16): resolution " << w << "x" << h << ", Scale Z = "
    << (hi - lo) * 100.0 / 512.0 << " (% of 512 m), X = Y = " << mpp * 100.0
    << " (cm per vertex), Location Z = " << (lo + hi) / 2 * 100.0 << " cm.\n";
  return s.str();
}

void write_obj(const fs::path& path, const cv::Mat1f& h, const MeshOptions& o) {
  check_mesh(h, o);
  const Grid g{h, o};
  std::string out;
  out.reserve(size_t(h.total()) * 40);
  out += "# reefgen height field: metres, +Y up, " + std::to_string(h.cols) + "x" + std::to_string(h.rows) +
         " vertices, vertical exaggeration " + std::to_string(o.exaggeration) + "\no island\n";
  char line[96];
  for (int r = 0; r < h.rows; ++r)
    for (int c = 0; c < h.cols; ++c) {
      std::snprintf(line, sizeof line, "v %.3f %.3f %.3f\n", g.x(c), g.y(r, c), g.z(r));
      out += line;
    }
  for (int r = 0; r + 1 < h.rows; ++r)
    for (int c = 0; c + 1 < h.cols; ++c) {
      const long a = long(r) * h.cols + c + 1, b = a + 1, cc = a + h.cols, d = cc + 1;  // 1-based
      std::snprintf(line, sizeof line, "f %ld %ld %ld\nf %ld %ld %ld\n", a, cc, b, b, cc, d);  // counter-clockwise from above
      out += line;
    }
  write_text_atomic(path, out);
}

void write_glb(const fs::path& path, const cv::Mat1f& h, const MeshOptions& o) {
  check_mesh(h, o);
  const Grid g{h, o};
  const size_t nv = size_t(h.total());
  std::vector<float> pos(nv * 3), nrm(nv * 3);
  float mn[3] = {1e30f, 1e30f, 1e30f}, mx[3] = {-1e30f, -1e30f, -1e30f};
  for (int r = 0; r < h.rows; ++r)
    for (int c = 0; c < h.cols; ++c) {
      const size_t i = size_t(r) * size_t(h.cols) + size_t(c);
      const float p[3] = {g.x(c), g.y(r, c), g.z(r)};
      for (int k = 0; k < 3; ++k) {
        pos[i * 3 + k] = p[k];
        mn[k] = std::min(mn[k], p[k]);
        mx[k] = std::max(mx[k], p[k]);
      }
      // Normal from central differences of the surface y(x, z).
      const int c0 = std::max(c - 1, 0), c1 = std::min(c + 1, h.cols - 1);
      const int r0 = std::max(r - 1, 0), r1 = std::min(r + 1, h.rows - 1);
      const double dydx = (g.y(r, c1) - g.y(r, c0)) / (g.x(c1) - g.x(c0));
      const double dydz = (g.y(r1, c) - g.y(r0, c)) / (g.z(r1) - g.z(r0));
      const double len = std::sqrt(dydx * dydx + 1 + dydz * dydz);
      nrm[i * 3 + 0] = float(-dydx / len);
      nrm[i * 3 + 1] = float(1 / len);
      nrm[i * 3 + 2] = float(-dydz / len);
    }
  std::vector<uint32_t> idx;
  idx.reserve(size_t(h.rows - 1) * size_t(h.cols - 1) * 6);
  for (int r = 0; r + 1 < h.rows; ++r)
    for (int c = 0; c + 1 < h.cols; ++c) {
      const uint32_t a = uint32_t(r * h.cols + c), b = a + 1, cc = a + uint32_t(h.cols), d = cc + 1;
      for (uint32_t v : {a, cc, b, b, cc, d}) idx.push_back(v);
    }
  const size_t pos_bytes = pos.size() * 4, nrm_bytes = nrm.size() * 4, idx_bytes = idx.size() * 4;
  const size_t bin_len = pos_bytes + nrm_bytes + idx_bytes;  // all multiples of 4
  using nlohmann::json;
  const json j = {
      {"asset", {{"version", "2.0"}, {"generator", "reefgen"}}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}, {"name", "island"}}}},
      {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}}}, {"indices", 2}, {"mode", 4}}}}}}},
      {"buffers", {{{"byteLength", bin_len}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", pos_bytes}, {"target", 34962}},
        {{"buffer", 0}, {"byteOffset", pos_bytes}, {"byteLength", nrm_bytes}, {"target", 34962}},
        {{"buffer", 0}, {"byteOffset", pos_bytes + nrm_bytes}, {"byteLength", idx_bytes}, {"target", 34963}}}},
      {"accessors",
       {{{"bufferView", 0}, {"componentType", 5126}, {"count", nv}, {"type", "VEC3"},
         {"min", {mn[0], mn[1], mn[2]}}, {"max", {mx[0], mx[1], mx[2]}}},
        {{"bufferView", 1}, {"componentType", 5126}, {"count", nv}, {"type", "VEC3"}},
        {{"bufferView", 2}, {"componentType", 5125}, {"count", idx.size()}, {"type", "SCALAR"}}}}};
  std::string js = j.dump();
  while (js.size() % 4) js += ' ';
  std::string out;
  auto u32 = [&](uint32_t v) { for (int k = 0; k < 4; ++k) out += char((v >> (8 * k)) & 0xff); };
  const size_t total = 12 + 8 + js.size() + 8 + bin_len;
  if (total > 0xffffffffull) throw Error(path.string() + ": mesh too large for GLB (4 GiB)");
  out.reserve(total);
  u32(0x46546C67);  // "glTF"
  u32(2);
  u32(uint32_t(total));
  u32(uint32_t(js.size()));
  u32(0x4E4F534A);  // "JSON"
  out += js;
  u32(uint32_t(bin_len));
  u32(0x004E4942);  // "BIN\0"
  auto append = [&](const void* p, size_t n) { out.append(static_cast<const char*>(p), n); };  // x86-64: little-endian
  append(pos.data(), pos_bytes);
  append(nrm.data(), nrm_bytes);
  append(idx.data(), idx_bytes);
  write_file_atomic(path, out.data(), out.size());
}

}  // namespace reefgen::infer
