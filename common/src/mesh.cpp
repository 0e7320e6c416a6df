#include "reefgen/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <fstream>
#include <numeric>
#include <sstream>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "reefgen/files.hpp"

namespace reefgen {

namespace {

void check_indices(const Mesh& m, const std::string& what) {
  if (!m.uvs.empty() && m.uvs.size() != m.positions.size()) throw Error(what + ": one uv per vertex needed");
  if (!m.colors.empty() && m.colors.size() != m.positions.size()) throw Error(what + ": one colour per vertex needed");
  if (!m.tangents.empty() && m.tangents.size() != m.positions.size()) throw Error(what + ": one tangent per vertex needed");
  for (const auto& t : m.triangles)
    for (uint32_t i : t)
      if (i >= m.positions.size()) throw Error(what + ": triangle index " + std::to_string(i) + " out of range");
}

// Meshes reefgen writes stay far below this; a FIFO or /dev/zero does not hang.
constexpr size_t kMaxMeshBytes = size_t(4) << 30;

std::string read_bytes(const fs::path& path) { return read_text(path, kMaxMeshBytes); }

uint32_t u32_at(const std::string& b, size_t off) {
  uint32_t v = 0;
  for (int k = 3; k >= 0; --k) v = (v << 8) | uint8_t(b[off + size_t(k)]);
  return v;
}

}  // namespace

std::vector<cv::Vec3f> vertex_normals(const Mesh& m) {
  std::vector<cv::Vec3d> acc(m.positions.size(), cv::Vec3d(0, 0, 0));
  for (const auto& t : m.triangles) {
    const cv::Vec3d a(m.positions[t[0]]), b(m.positions[t[1]]), c(m.positions[t[2]]);
    const cv::Vec3d n = (b - a).cross(c - a);  // length = 2·area: area weighting for free
    for (uint32_t i : t) acc[i] += n;
  }
  std::vector<cv::Vec3f> out(acc.size());
  for (size_t i = 0; i < acc.size(); ++i) {
    const double len = cv::norm(acc[i]);
    out[i] = len > 0 ? cv::Vec3f(acc[i] / len) : cv::Vec3f(0, 1, 0);
  }
  return out;
}

std::vector<cv::Vec2f> planar_uvs(const Mesh& m, double ex, double ez) {
  if (!(ex > 0 && ez > 0)) throw Error("planar_uvs: extent must be > 0");
  std::vector<cv::Vec2f> uv(m.positions.size());
  for (size_t i = 0; i < uv.size(); ++i)
    uv[i] = {float(m.positions[i][0] / ex + 0.5), float(m.positions[i][2] / ez + 0.5)};  // glTF: v down, as image rows
  return uv;
}

void write_obj(const fs::path& path, const Mesh& m, const std::string& comment) {
  check_indices(m, path.string());
  std::string out;
  out.reserve(m.positions.size() * 36 + m.triangles.size() * 24 + comment.size() + 32);
  out += "# " + comment + "\no island\n";
  char line[128];
  for (size_t i = 0; i < m.positions.size(); ++i) {
    const auto& p = m.positions[i];
    if (m.colors.empty()) {
      std::snprintf(line, sizeof line, "v %.3f %.3f %.3f\n", p[0], p[1], p[2]);
    } else {  // the common "v x y z r g b" extension (Blender, MeshLab)
      const auto& c = m.colors[i];
      std::snprintf(line, sizeof line, "v %.3f %.3f %.3f %.4f %.4f %.4f\n", p[0], p[1], p[2], c[0], c[1], c[2]);
    }
    out += line;
  }
  for (const auto& t : m.uvs) {
    std::snprintf(line, sizeof line, "vt %.5f %.5f\n", t[0], 1.0f - t[1]);  // OBJ: v up
    out += line;
  }
  for (const auto& t : m.triangles) {
    const unsigned long a = t[0] + 1ul, b = t[1] + 1ul, c = t[2] + 1ul;
    if (m.uvs.empty()) std::snprintf(line, sizeof line, "f %lu %lu %lu\n", a, b, c);
    else std::snprintf(line, sizeof line, "f %lu/%lu %lu/%lu %lu/%lu\n", a, a, b, b, c, c);
    out += line;
  }
  write_text_atomic(path, out);
}

namespace {

// The images of `t` appended to the binary chunk (each view padded to 4
// bytes, as GLB wants), and the matte material that shows them.
void add_textures(nlohmann::json& j, std::string& bin, const GlbTextures& t, const std::string& name) {
  using nlohmann::json;
  json images = json::array(), textures = json::array();
  json pbr = {{"metallicFactor", 0}, {"roughnessFactor", 1}};
  json material = {{"name", name + "-textured"}};
  auto add_image = [&](const std::string& png) {
    j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", png.size()}});
    bin += png;
    while (bin.size() % 4) bin += char(0);
    images.push_back({{"bufferView", j["bufferViews"].size() - 1}, {"mimeType", "image/png"}});
    textures.push_back({{"sampler", 0}, {"source", images.size() - 1}});
    return textures.size() - 1;
  };
  if (!t.base_colour_png.empty()) pbr["baseColorTexture"] = {{"index", add_image(t.base_colour_png)}};
  if (!t.normal_png.empty()) material["normalTexture"] = {{"index", add_image(t.normal_png)}};
  material["pbrMetallicRoughness"] = pbr;
  j["materials"] = {material};
  if (images.empty()) return;
  j["images"] = images;
  j["textures"] = textures;
  // Linear, mipmapped, clamped at the island's edges (no wrap-around seam).
  j["samplers"] = {{{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 33071}, {"wrapT", 33071}}};
  j["buffers"][0]["byteLength"] = bin.size();
}

}  // namespace

void write_glb(const fs::path& path, const Mesh& m, const std::string& name, const GlbTextures* textures) {
  check_indices(m, path.string());
  if (textures && m.uvs.empty()) throw Error(path.string() + ": textures need texture coordinates");
  if (m.positions.empty() || m.triangles.empty()) throw Error(path.string() + ": empty mesh");
  const std::vector<cv::Vec3f> nrm = m.normals.size() == m.positions.size() ? m.normals : vertex_normals(m);
  float mn[3] = {1e30f, 1e30f, 1e30f}, mx[3] = {-1e30f, -1e30f, -1e30f};
  for (const auto& p : m.positions)
    for (int k = 0; k < 3; ++k) {
      mn[k] = std::min(mn[k], p[k]);
      mx[k] = std::max(mx[k], p[k]);
    }
  const size_t nv = m.positions.size();
  using nlohmann::json;
  // One buffer of consecutive views: positions, normals, [uvs], [colours], indices.
  std::string bin;
  // Reserved once: a 1025² grid's 75 MB grown by doubling cost a second
  // copy and its page faults.
  bin.reserve(nv * (12 + 12 + (m.tangents.empty() ? 0 : 16) + (m.uvs.empty() ? 0 : 8) + (m.colors.empty() ? 0 : 12)) +
              m.triangles.size() * 12 +
              (textures ? textures->base_colour_png.size() + textures->normal_png.size() + 8 : 0));
  json views = json::array(), accessors = json::array(), attributes = json::object();
  auto add_view = [&](const void* data, size_t bytes, int target) {
    views.push_back({{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}, {"target", target}});
    bin.append(static_cast<const char*>(data), bytes);  // x86-64 and aarch64: little-endian, as glTF requires
    return int(views.size() - 1);
  };
  auto add_attribute = [&](const char* name, const void* data, size_t elem_bytes, const char* type) {
    json acc = {{"bufferView", add_view(data, nv * elem_bytes, 34962)}, {"componentType", 5126}, {"count", nv}, {"type", type}};
    if (std::string(name) == "POSITION") acc["min"] = {mn[0], mn[1], mn[2]}, acc["max"] = {mx[0], mx[1], mx[2]};
    accessors.push_back(acc);
    attributes[name] = accessors.size() - 1;
  };
  add_attribute("POSITION", m.positions.data(), 12, "VEC3");
  add_attribute("NORMAL", nrm.data(), 12, "VEC3");
  if (!m.tangents.empty()) add_attribute("TANGENT", m.tangents.data(), 16, "VEC4");
  if (!m.uvs.empty()) add_attribute("TEXCOORD_0", m.uvs.data(), 8, "VEC2");
  if (!m.colors.empty()) add_attribute("COLOR_0", m.colors.data(), 12, "VEC3");
  accessors.push_back({{"bufferView", add_view(m.triangles.data(), m.triangles.size() * 12, 34963)},
                       {"componentType", 5125}, {"count", m.triangles.size() * 3}, {"type", "SCALAR"}});
  json primitive = {{"attributes", attributes}, {"indices", accessors.size() - 1}, {"mode", 4}};
  json j = {{"asset", {{"version", "2.0"}, {"generator", "reefgen"}}},
            {"scene", 0},
            {"scenes", {{{"nodes", {0}}}}},
            {"nodes", {{{"mesh", 0}, {"name", name}}}},
            {"buffers", {{{"byteLength", bin.size()}}}},
            {"bufferViews", views},
            {"accessors", accessors}};
  if (textures) {
    add_textures(j, bin, *textures, name);
    primitive["material"] = 0;
  } else if (!m.colors.empty()) {
    // COLOR_0 multiplies the base colour: a white, matte material shows it as is.
    j["materials"] = {{{"name", name + "-vertex-colours"},
                       {"pbrMetallicRoughness", {{"baseColorFactor", {1, 1, 1, 1}}, {"metallicFactor", 0}, {"roughnessFactor", 1}}}}};
    primitive["material"] = 0;
  }
  j["meshes"] = {{{"primitives", {primitive}}}};
  const size_t bin_len = bin.size();  // every view a multiple of 4 bytes
  std::string js = j.dump();
  while (js.size() % 4) js += ' ';
  const size_t total = 12 + 8 + js.size() + 8 + bin_len;
  if (total > 0xffffffffull) throw Error(path.string() + ": mesh too large for GLB (4 GiB)");
  std::string head;
  auto u32 = [&](uint32_t v) { for (int k = 0; k < 4; ++k) head += char((v >> (8 * k)) & 0xff); };
  u32(0x46546C67);  // "glTF"
  u32(2);
  u32(uint32_t(total));
  u32(uint32_t(js.size()));
  u32(0x4E4F534A);  // "JSON"
  head += js;
  u32(uint32_t(bin_len));
  u32(0x004E4942);  // "BIN\0"
  // Header and binary chunk written in turn: no second copy of a 79 MB buffer.
  AtomicTextWriter out(path);
  out.write(head);
  out.write(bin);
  out.commit();
}

Mesh read_obj(const fs::path& path) {
  std::istringstream in(read_bytes(path));
  Mesh m;
  std::string line;
  size_t line_no = 0;
  auto fail = [&](const std::string& why) {
    throw Error(path.string() + ":" + std::to_string(line_no) + ": " + why);
  };
  while (std::getline(in, line)) {
    ++line_no;
    std::istringstream s(line);
    std::string tag;
    if (!(s >> tag) || tag[0] == '#') continue;
    if (tag == "v") {
      cv::Vec3f p, c;
      if (!(s >> p[0] >> p[1] >> p[2])) fail("vertex needs three numbers");
      m.positions.push_back(p);
      if (s >> c[0] >> c[1] >> c[2]) m.colors.push_back(c);
    } else if (tag == "vt") {
      cv::Vec2f t;
      if (!(s >> t[0] >> t[1])) fail("texture coordinate needs two numbers");
      m.uvs.push_back({t[0], 1.0f - t[1]});
    } else if (tag == "f") {
      std::vector<long> ix;
      std::string tok;
      while (s >> tok) {
        long i = 0;
        try {
          i = std::stol(tok.substr(0, tok.find('/')));
        } catch (const std::exception&) {
          fail("bad face index '" + tok + "'");
        }
        if (i < 0) i += long(m.positions.size()) + 1;
        if (i < 1 || i > long(m.positions.size())) fail("face index " + tok + " out of range");
        ix.push_back(i - 1);
      }
      if (ix.size() < 3) fail("face needs at least three vertices");
      for (size_t k = 1; k + 1 < ix.size(); ++k)  // fan: polygons become triangles
        m.triangles.push_back({uint32_t(ix[0]), uint32_t(ix[k]), uint32_t(ix[k + 1])});
    }
  }
  return m;
}

Mesh read_glb(const fs::path& path) {
  const std::string b = read_bytes(path);
  const std::string name = path.string();
  if (b.size() < 28 || b.compare(0, 4, "glTF") != 0) throw Error(name + ": not a binary glTF file");
  if (u32_at(b, 4) != 2) throw Error(name + ": glTF version is not 2");
  if (u32_at(b, 8) != b.size()) throw Error(name + ": length in header does not match the file (truncated?)");
  const uint32_t json_len = u32_at(b, 12);
  if (u32_at(b, 16) != 0x4E4F534A || 20 + size_t(json_len) + 8 > b.size()) throw Error(name + ": bad JSON chunk");
  nlohmann::json j;
  try {
    j = parse_json_checked(b.substr(20, json_len), name + " (its JSON chunk)");
  } catch (const std::exception& e) {
    throw Error(name + ": JSON chunk does not parse (" + e.what() + ")");
  }
  const size_t bin_at = 20 + json_len;
  const uint32_t bin_len = u32_at(b, bin_at);
  if (u32_at(b, bin_at + 4) != 0x004E4942 || bin_at + 8 + bin_len > b.size()) throw Error(name + ": bad BIN chunk");
  const char* bin = b.data() + bin_at + 8;
  Mesh m;
  try {
    const auto& prim = j.at("meshes").at(0).at("primitives").at(0);
    if (prim.value("mode", 4) != 4) throw Error(name + ": primitive is not a triangle list");
    // Returns (pointer, count, componentType) of an accessor, checked against the chunk.
    auto view = [&](int accessor, size_t elem_size) {
      const auto& a = j.at("accessors").at(accessor);
      const auto& v = j.at("bufferViews").at(a.at("bufferView").get<int>());
      const size_t off = v.value("byteOffset", size_t(0)) + a.value("byteOffset", size_t(0));
      const size_t count = a.at("count").get<size_t>();
      if (v.contains("byteStride") && v["byteStride"].get<size_t>() != elem_size)
        throw Error(name + ": interleaved buffers are not supported");
      if (off + count * elem_size > bin_len) throw Error(name + ": accessor runs past the BIN chunk");
      return std::make_pair(bin + off, count);
    };
    const int pa = prim.at("attributes").at("POSITION").get<int>();
    if (j["accessors"][pa].at("componentType") != 5126) throw Error(name + ": positions are not float");
    const auto [pp, nv] = view(pa, 12);
    m.positions.resize(nv);
    std::memcpy(static_cast<void*>(m.positions.data()), pp, nv * 12);
    const int ia = prim.at("indices").get<int>();
    const int type = j["accessors"][ia].at("componentType").get<int>();
    const size_t isz = type == 5125 ? 4 : type == 5123 ? 2 : type == 5121 ? 1 : 0;
    if (!isz) throw Error(name + ": unsupported index type " + std::to_string(type));
    const auto [ip, ni] = view(ia, isz);
    if (ni % 3) throw Error(name + ": index count is not a multiple of 3");
    auto index = [&, ip = ip](size_t k) -> uint32_t {
      uint32_t v = 0;
      std::memcpy(&v, ip + k * isz, isz);
      return v;
    };
    for (size_t k = 0; k < ni; k += 3) m.triangles.push_back({index(k), index(k + 1), index(k + 2)});
    if (prim.at("attributes").contains("TEXCOORD_0")) {
      const auto [tp, nt] = view(prim["attributes"]["TEXCOORD_0"].get<int>(), 8);
      m.uvs.resize(nt);
      std::memcpy(static_cast<void*>(m.uvs.data()), tp, nt * 8);
    }
    if (prim.at("attributes").contains("COLOR_0")) {
      const auto [cp, nc] = view(prim["attributes"]["COLOR_0"].get<int>(), 12);
      m.colors.resize(nc);
      std::memcpy(static_cast<void*>(m.colors.data()), cp, nc * 12);
    }
    if (prim.at("attributes").contains("NORMAL")) {
      const auto [np, nn] = view(prim["attributes"]["NORMAL"].get<int>(), 12);
      m.normals.resize(nn);
      std::memcpy(static_cast<void*>(m.normals.data()), np, nn * 12);
    }
  } catch (const nlohmann::json::exception& e) {
    throw Error(name + ": glTF JSON lacks a mesh this reader understands (" + e.what() + ")");
  }
  check_indices(m, name);
  return m;
}

MeshReport inspect_mesh(const Mesh& m) {
  check_indices(m, "mesh");
  MeshReport r;
  struct EdgeUse {
    int count = 0;
    int direction = 0;  // +1 per use running low→high index, −1 per use running high→low
  };
  std::unordered_map<uint64_t, EdgeUse> edges;
  edges.reserve(m.triangles.size() * 2);
  double mean_len2 = 0;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) mean_len2 += cv::norm(m.positions[t[k]] - m.positions[t[(k + 1) % 3]], cv::NORM_L2SQR);
  mean_len2 /= std::max<size_t>(1, m.triangles.size() * 3);
  for (const auto& t : m.triangles) {
    const cv::Vec3d a(m.positions[t[0]]), b(m.positions[t[1]]), c(m.positions[t[2]]);
    const cv::Vec3d n = (b - a).cross(c - a);
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || cv::norm(n) / 2 < 1e-9 * mean_len2) ++r.degenerate;
    r.volume_m3 += a.dot(b.cross(c)) / 6;
    for (int k = 0; k < 3; ++k) {
      const uint32_t u = t[k], v = t[(k + 1) % 3];
      auto& e = edges[(uint64_t(std::min(u, v)) << 32) | std::max(u, v)];
      ++e.count;
      e.direction += u < v ? 1 : -1;
    }
  }
  for (const auto& [key, e] : edges) {
    if (e.count == 1) ++r.open_edges;
    else if (e.count > 2) ++r.nonmanifold_edges;
    else if (e.direction != 0) ++r.misoriented_edges;
  }
  // Vertex fans: the triangles around a vertex must be one edge-connected fan.
  std::vector<std::vector<uint32_t>> around(m.positions.size());
  for (uint32_t t = 0; t < m.triangles.size(); ++t)
    for (uint32_t v : m.triangles[t]) around[v].push_back(t);
  std::vector<uint32_t> parent;
  for (uint32_t v = 0; v < around.size(); ++v) {
    const auto& ts = around[v];
    if (ts.size() < 2) continue;
    parent.resize(ts.size());
    std::iota(parent.begin(), parent.end(), 0u);
    std::function<uint32_t(uint32_t)> find = [&](uint32_t x) { return parent[x] == x ? x : parent[x] = find(parent[x]); };
    // Two triangles around v are neighbours when they share another vertex (an edge through v).
    std::unordered_map<uint32_t, uint32_t> first_with;
    for (uint32_t k = 0; k < ts.size(); ++k)
      for (uint32_t w : m.triangles[ts[k]]) {
        if (w == v) continue;
        auto [it, inserted] = first_with.emplace(w, k);
        if (!inserted) parent[find(k)] = find(it->second);
      }
    size_t roots = 0;
    for (uint32_t k = 0; k < ts.size(); ++k) roots += find(k) == k;
    if (roots > 1) ++r.nonmanifold_vertices;
  }
  return r;
}

}  // namespace reefgen
