#pragma once
// Height-field formats terrain tools import (docs/EXPORTS.md). All written
// atomically; heights in metres, sea level 0.
#include <filesystem>
#include <map>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/files.hpp"
#include "reefgen/mesh.hpp"

namespace reefgen {

// The 16-bit code of every height, v = round(65535·(h − lo)/(hi − lo)),
// clamped: the one mapping of PNG16, R16 and the engine bundles.
cv::Mat1w to_u16(const cv::Mat1f& height_m, double lo_m, double hi_m);

// 16-bit greyscale PNG, linear: v = round(65535·(h − lo)/(hi − lo)).
void write_png16(const std::filesystem::path& path, const cv::Mat1f& height_m, double lo_m, double hi_m);
cv::Mat1f read_png16(const std::filesystem::path& path, double lo_m, double hi_m, int max_side = kMaxImageSidePx);

// Headerless little-endian uint16, row 0 first, W·H·2 bytes (Unity / Unreal
// "RAW 16-bit"), same linear mapping as PNG16.
void write_r16(const std::filesystem::path& path, const cv::Mat1f& height_m, double lo_m, double hi_m);
// What to type in Unity's and Unreal's import dialogs for such a file.
std::string r16_import_note(int width, int height, double lo_m, double hi_m, double metres_per_px);

// The range a 16-bit export maps to 0..65535: the field's own, widened to
// whole metres (and to 1 m at least), so nothing is ever clipped — a model's
// or a preset's nominal range would clip a 608 m peak at 560 m.
struct HeightRange {
  double lo_m = 0, hi_m = 1;
};
HeightRange export_range(const cv::Mat1f& height_m);

// The numbers each engine's import needs for a 16-bit file of that range
// (sidecar "import" object; docs/INFERENCE.md explains them): Unreal's Z scale
// (% of 512 m) and location, Unity's terrain height and position, Blender's
// displacement strength and midlevel. JSON text, one object.
std::string engine_import_json(int width, int height, const HeightRange& r, double metres_per_px);

struct MeshOptions {
  double metres_per_px = kCanvasWorldSizeM / 256;  // horizontal spacing of grid vertices
  double exaggeration = 1.0;            // vertical scale factor, (0, 100]
};
// Grid mesh, one vertex per pixel, two triangles per cell, +Y up (glTF and
// Blender's OBJ importer convention), centred on the canvas, metres.
Mesh grid_mesh(const cv::Mat1f& height_m, const MeshOptions& o);
void write_obj(const std::filesystem::path& path, const cv::Mat1f& height_m, const MeshOptions& o);
void write_glb(const std::filesystem::path& path, const cv::Mat1f& height_m, const MeshOptions& o);

// The files of one height field, named from one prefix: PREFIX.height.exr,
// PREFIX.height.png (16-bit), PREFIX.r16, PREFIX.obj / PREFIX.glb and
// PREFIX.preview.png. Written by `infer`, `terrain` and the studio's export
// alike, so a file and its import numbers are the same whoever wrote it.
struct HeightFiles {
  bool exr = true, png16 = false, r16 = false, preview = false;
  std::string mesh;                   // "", "obj" or "glb"
  std::filesystem::path exr_path;     // "" = PREFIX.height.exr
  std::filesystem::path mesh_path;    // "" = PREFIX.<mesh>
  double exaggeration = 1.0;          // the mesh's vertical scale, (0, 100]
  std::map<std::string, std::string> exr_attributes;  // beside reefgen:version and reefgen:metres_per_pixel
};
// Stages each requested file of height_m (metres_per_px apart) in `staged`
// (nothing is in place before staged.commit()) and returns what a sidecar
// says about them: "files" {kind: file name}; "png16" / "r16": the linear
// range (the field's own, export_range: never clipped), the byte order and
// each engine's import numbers (engine_import_json), R16's import note; "mesh".
nlohmann::json stage_height_files(StagedOutputs& staged, const std::filesystem::path& prefix,
                                  const cv::Mat1f& height_m, double metres_per_px, const HeightFiles& f);

}  // namespace reefgen
