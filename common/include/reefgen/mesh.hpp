#pragma once
// Triangle meshes for terrain tools: one indexed list, metres, +Y up (glTF's
// and Blender's importer convention), counter-clockwise seen from outside.
// Writers are atomic; the readers exist so tests (and users) can check what
// was written without Blender.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace reefgen {

struct Mesh {
  std::vector<cv::Vec3f> positions;                  // metres, x right, y up, z towards the viewer
  std::vector<std::array<uint32_t, 3>> triangles;    // indices into positions, CCW from outside
  std::vector<cv::Vec3f> normals;                    // per vertex; empty = area-weighted from the faces
  std::vector<cv::Vec2f> uvs;                        // per vertex texture coordinates, [0, 1]; optional
  std::vector<cv::Vec3f> colors;                     // per vertex linear RGB, [0, 1]; optional
  std::vector<cv::Vec4f> tangents;                   // per vertex unit xyz + handedness w (glTF TANGENT); optional, GLB only
};
// Top-down planar texture coordinates: u along x, v along z, [0, 1] over the
// given extent (metres, centred on the origin), so a top-view image of that
// extent (a preview, a painting) drapes onto the mesh.
std::vector<cv::Vec2f> planar_uvs(const Mesh& m, double extent_x_m, double extent_z_m);

// Area-weighted vertex normals (unit length; +Y for isolated vertices).
std::vector<cv::Vec3f> vertex_normals(const Mesh& m);

// Wavefront OBJ ("v x y z [r g b]", "vt u v", then "f a b c" or "f a/a b/b c/c",
// 1-based), `comment` on the first line.
void write_obj(const std::filesystem::path& path, const Mesh& m, const std::string& comment);
// Textures a GLB carries inside it (PNG bytes; empty = none): a matte
// material with baseColorTexture (sRGB) and normalTexture (tangent space,
// OpenGL convention: green = +v up the image), both on TEXCOORD_0.
struct GlbTextures {
  std::string base_colour_png, normal_png;
};
// Binary glTF 2.0: POSITION, NORMAL, [TEXCOORD_0], [COLOR_0 with a plain
// matte material so importers show the colours], uint32 indices, one node
// named `name`; with `textures`, their images in the binary chunk (needs uvs).
void write_glb(const std::filesystem::path& path, const Mesh& m, const std::string& name,
               const GlbTextures* textures = nullptr);

// Read back what the writers produce (triangles only; OBJ "f a/b/c" forms and
// negative indices accepted). Throw reefgen::Error naming the file on anything else.
Mesh read_obj(const std::filesystem::path& path);
Mesh read_glb(const std::filesystem::path& path);

// Topology of a mesh as a closed surface needs it.
struct MeshReport {
  size_t open_edges = 0;         // edges used by one triangle (holes in the surface)
  size_t nonmanifold_edges = 0;  // edges used by more than two triangles
  size_t misoriented_edges = 0;  // edges whose two triangles run the same way (inconsistent winding)
  size_t degenerate = 0;         // triangles with a repeated index or area < 1e-9 of the mean edge²
  size_t nonmanifold_vertices = 0;  // vertices whose triangles form more than one fan
  double volume_m3 = 0;          // signed; > 0 when closed and wound outwards
  bool closed_manifold() const {
    return open_edges == 0 && nonmanifold_edges == 0 && misoriented_edges == 0 && degenerate == 0 &&
           nonmanifold_vertices == 0;
  }
};
MeshReport inspect_mesh(const Mesh& m);

}  // namespace reefgen
