// The Blender bundle: a textured GLB and the displacement recipe as a
// script (docs/ENGINES.md "Blender").
#include <algorithm>
#include <cmath>

#include "reefgen/error.hpp"
#include "reefgen/heightfile.hpp"
#include "reefgen/io.hpp"
#include "reefgen/mesh.hpp"
#include "reefgen/parallel.hpp"
#include "stages.hpp"

namespace reefgen::engines::detail {

namespace fs = std::filesystem;

namespace {

// The GLB's grid: 1025² vertices (2 M triangles, ~70 MB) is what Blender's
// glTF importer takes in seconds; larger islands keep their detail in the
// normal texture.
constexpr int kMeshMaxSide = 1025;
// Textures: 4096² is the largest size every GPU and glTF viewer takes.
constexpr int kTextureMaxSide = 4096;

cv::Vec3f unit(const cv::Vec3f& v) {
  const float len = std::sqrt(v.dot(v));
  return len > 0 ? v / len : cv::Vec3f(0, 0, 1);
}

// The true normals (x east, y north, z up) in the tangent frame of the mesh
// they are drawn on: tangent = east (+u), bitangent = north (up the image,
// glTF's and MikkTSpace's +v in Blender), normal = the mesh's. RGB8 as BGR
// for the PNG encoder.
// The tangent of a surface normal: east made perpendicular to it. The GLB
// carries the same at its vertices (TANGENT, w = +1: bitangent = north).
cv::Vec3f east_tangent(const cv::Vec3f& nm) { return unit(cv::Vec3f(1, 0, 0) - nm[0] * nm); }

cv::Mat3b tangent_space_normals(const cv::Mat3f& truth, const cv::Mat3f& mesh, int threads) {
  cv::Mat3b out(truth.size());
  // Rows are independent: the same bytes whatever the thread count.
  parallel_for(size_t(truth.rows), threads, [&](size_t row) {
    const int y = int(row);
    for (int x = 0; x < truth.cols; ++x) {
      const cv::Vec3f n = unit(truth(y, x)), nm = unit(mesh(y, x));
      const cv::Vec3f t = east_tangent(nm), b = nm.cross(t);
      const cv::Vec3f ts = unit(cv::Vec3f(n.dot(t), n.dot(b), n.dot(nm)));
      auto code = [](float v) { return cv::saturate_cast<uint8_t>(std::lround((v + 1) * 127.5f)); };
      out(y, x) = cv::Vec3b(code(ts[2]), code(ts[1]), code(ts[0]));
    }
  });
  return out;
}

// A grid mesh's vertex normals as a field (x east, y north, z up).
cv::Mat3f normals_of(const Mesh& m, int side) {
  cv::Mat3f out(side, side);
  for (int i = 0; i < side * side; ++i) {
    const cv::Vec3f& n = m.normals[size_t(i)];  // glTF: x east, y up, z south
    out(i / side, i % side) = cv::Vec3f(n[0], -n[2], n[1]);
  }
  return out;
}

// The displacement recipe, run by Blender itself: a grid of one vertex per
// pixel whose UVs hit pixel centres, the EXR read as data (Non-Color), no
// interpolation, edges extended and no clamping, so negative heights stay.
std::string displace_script(const std::string& name, int side, double metres_per_px, double lo_m, double hi_m) {
  return "# reefgen: the island " + name + " as a displaced grid in Blender (3.x or 4.x).\n"
         "# Run: blender --python " + name + ".displace.py   or Scripting > Open > Run Script.\n"
         "# One vertex per pixel of " + name + ".height.exr (metres, sea level 0, " + format_num("%.1f", lo_m) + " ... " +
         format_num("%.1f", hi_m) + " m).\n"
         "import os\nimport bpy\nimport numpy as np\n\n"
         "HERE = os.path.dirname(os.path.abspath(__file__))\n"
         "NAME = '" + name + "'\nSIDE = " + std::to_string(side) + "\nSPACING_M = " + format_num("%.9g", metres_per_px) + "\n\n"
         "n = SIDE\nr, c = np.mgrid[0:n, 0:n]\n"
         "xy = np.stack([(c - (n - 1) / 2) * SPACING_M, ((n - 1) / 2 - r) * SPACING_M, 0 * r], -1).reshape(-1, 3)\n"
         "a = (r[:-1, :-1] * n + c[:-1, :-1]).ravel()\n"
         "quads = np.stack([a + n, a + n + 1, a + 1, a], -1)  # counter-clockwise seen from above\n"
         "me = bpy.data.meshes.new(NAME)\n"
         "me.vertices.add(n * n)\nme.vertices.foreach_set('co', xy.astype(np.float32).ravel())\n"
         "me.loops.add(quads.size)\nme.loops.foreach_set('vertex_index', quads.astype(np.int32).ravel())\n"
         "me.polygons.add(len(quads))\n"
         "me.polygons.foreach_set('loop_start', np.arange(0, quads.size, 4, dtype=np.int32))\n"
         "me.polygons.foreach_set('loop_total', np.full(len(quads), 4, dtype=np.int32))\n"
         "uv = me.uv_layers.new(name='UVMap')\n"
         "v = quads.ravel()\n"
         "uvs = np.stack([(v % n + 0.5) / n, 1 - (v // n + 0.5) / n], -1)  # pixel centres; image row 0 at the top\n"
         "uv.data.foreach_set('uv', uvs.astype(np.float32).ravel())\n"
         "me.update()\nme.validate()\n"
         "ob = bpy.data.objects.new(NAME + '.displaced', me)\nbpy.context.collection.objects.link(ob)\n\n"
         "img = bpy.data.images.load(os.path.join(HERE, NAME + '.height.exr'))\n"
         "img.colorspace_settings.name = 'Non-Color'\n"
         "tex = bpy.data.textures.new(NAME + '.heights', 'IMAGE')\ntex.image = img\n"
         "tex.use_interpolation = False\ntex.use_mipmap = False\ntex.filter_type = 'BOX'\n"
         "tex.extension = 'EXTEND'\ntex.use_clamp = False  # on by default: it would flatten the sea floor to 0 m\n"
         "mod = ob.modifiers.new('reefgen heights', 'DISPLACE')\n"
         "mod.texture = tex\nmod.texture_coords = 'UV'\nmod.uv_layer = 'UVMap'\nmod.direction = 'Z'\n"
         "mod.strength = 1.0\nmod.mid_level = 0.0\n\n"
         "# The material colours on it (lit by Blender; the GLB carries the same texture).\n"
         "mat = bpy.data.materials.new(NAME + '.materials')\nmat.use_nodes = True\n"
         "node = mat.node_tree.nodes.new('ShaderNodeTexImage')\n"
         "node.image = bpy.data.images.load(os.path.join(HERE, NAME + '.color.png'))\n"
         "bsdf = mat.node_tree.nodes['Principled BSDF']\n"
         "mat.node_tree.links.new(node.outputs['Color'], bsdf.inputs['Base Color'])\n"
         "bsdf.inputs['Roughness'].default_value = 1.0\nme.materials.append(mat)\n";
}

// The GLB's grid (m² vertices, uvs on the T² textures' texel grid, tangents)
// and its textures: the materials' colours and the tangent-space normals.
std::pair<Mesh, GlbTextures> textured_mesh(const BundleInput& in, int m, int T, int threads) {
  const int n = in.height_m.cols;
  const double span_m = in.metres_per_px * (n - 1);
  const cv::Mat1f hm = m == n ? in.height_m : resample_corners(in.height_m, m);
  Mesh mesh = grid_mesh(hm, {span_m / (m - 1), 1.0});
  // Vertex k sits at texel k·(T − 1)/(m − 1): the textures are corner-aligned like the mesh.
  for (int r = 0; r < m; ++r)
    for (int c = 0; c < m; ++c)
      mesh.uvs[size_t(r) * size_t(m) + size_t(c)] = {float((c * double(T - 1) / (m - 1) + 0.5) / T),
                                                      float((r * double(T - 1) / (m - 1) + 0.5) / T)};
  mesh.tangents.resize(mesh.normals.size());
  for (size_t i = 0; i < mesh.normals.size(); ++i) {
    // glTF's axes (x east, y up, z south) to the texture's (east, north, up) and back.
    const cv::Vec3f& g = mesh.normals[i];
    const cv::Vec3f t = east_tangent(unit(cv::Vec3f(g[0], -g[2], g[1])));
    mesh.tangents[i] = {t[0], t[2], -t[1], 1.0f};
  }
  const terrain::Layers& L = *in.layers;
  const cv::Mat3f truth = T == n ? L.normal : resample_corners3(L.normal, T);
  const cv::Mat3f under = resample_corners3(normals_of(mesh, m), T);
  const cv::Mat3b normal = tangent_space_normals(truth, under, threads);
  GlbTextures tex;
  parallel_for(2, threads, [&](size_t k) {
    if (k) tex.normal_png = encode_png8(normal);
    else tex.base_colour_png = encode_png8(terrain::material_colour_map(T == n ? L : weights_at(L, T), false));
  });
  return {std::move(mesh), std::move(tex)};
}

}  // namespace

nlohmann::json stage_blender(StagedOutputs& staged, const fs::path& dir, const std::string& name,
                             const BundleInput& in, int threads) {
  const int n = in.height_m.cols, m = std::min(n, kMeshMaxSide), T = std::min(n, kTextureMaxSide);
  const double span_m = in.metres_per_px * (n - 1);
  const ExrAttributes attrs{{"reefgen:metres_per_pixel", format_num("%.9g", in.metres_per_px)}};
  const cv::Mat1f& h = in.height_m;
  double lo = 0, hi = 0;
  cv::minMaxLoc(h, &lo, &hi);
  const std::string script = displace_script(name, n, in.metres_per_px, lo, hi);
  // The GLB (built and written in one job, the longest) beside the EXR and
  // the colour map (the same colours as the GLB's texture, encoded again
  // while the GLB is being built).
  staged.write_all({{dir / (name + ".glb"),
                     [&](const fs::path& p) {
                       const auto [mesh, tex] = textured_mesh(in, m, T, threads);
                       write_glb(p, mesh, name, &tex);
                     }},
                    {dir / (name + ".height.exr"), [&](const fs::path& p) { write_exr_height(p, h, attrs, kExrZipLevel); }},
                    {dir / (name + ".color.png"),
                     [&](const fs::path& p) {
                       const terrain::Layers& L = *in.layers;
                       write_png(p, terrain::material_colour_map(T == n ? L : weights_at(L, T), false));
                     }},
                    {dir / (name + ".displace.py"), [&](const fs::path& p) { write_text_atomic(p, script); }}},
                   threads);
  const std::string readme =
      "reefgen island for Blender\n\n"
      "A. The mesh: File > Import > glTF 2.0, " + name + ".glb. " + std::to_string(m) + "x" + std::to_string(m) +
      " vertices, " + format_num("%.3f", span_m) + " m across, heights in metres (" + format_num("%.1f", lo) + " ... " +
      format_num("%.1f", hi) + " m, sea level at z = 0),\n"
      "   north = +Y; base colour (the materials) and normal textures " + std::to_string(T) + "x" + std::to_string(T) +
      " inside it.\n"
      "   (Debian 12's Blender 3.4 with numpy 1.24 fails in the glTF importer with \"module 'numpy' has no\n"
      "   attribute 'bool'\": type  import numpy; numpy.bool = bool  in Blender's Python console first.)\n"
      "B. Full detail by displacement: blender --python " + name + ".displace.py (or Scripting > Open > Run Script).\n"
      "   It builds a grid of " + std::to_string(n) + "x" + std::to_string(n) + " vertices, " +
      format_num("%.4f", in.metres_per_px) + " m apart, and a Displace modifier reading " + name + ".height.exr with:\n"
      "   Texture Coordinates UV, Direction Z, Strength 1, Midlevel 0; image Non-Color, Interpolation off,\n"
      "   Extension Extend, and Clamp OFF (Clamp is on by default and sets every height below sea level to 0 m).\n";
  stage_text(staged, dir / "README.txt", readme);
  return {{"engine", "blender"},         {"mesh", name + ".glb"},       {"mesh_side_px", m},
          {"texture_side_px", T},        {"heightmap", name + ".height.exr"}, {"displace_script", name + ".displace.py"},
          {"color_map", name + ".color.png"}, {"span_m", span_m},      {"side_px", n},
          {"up_axis", "glTF +Y (Blender +Z)"}};
}

}  // namespace reefgen::engines::detail
