#pragma once
// Floating islands from a painting (IslandPaint, Li 2021), as closed meshes.
//
// The painting is a top view of the island's top (top colours, e.g. green and
// white snow) and, optionally, the rock hanging under it (bottom colour,
// brown), painted below the top as seen from the front-above: how far the
// brown reaches below the top's lowest row sets the depth of the rock. Each
// top blob becomes one closed shell (docs/ISLANDS.md):
//   silhouette: contour of the blob, Douglas–Peucker polygon, grid trimmed to it;
//   basemaps per row v (u = column): μ = (u_min+u_max)/2, σ = (u_max−u_min)/2,
//     B = sin(arccos(|u−μ|/σ)), c_b = μ+σ − [(1−t)μ(v_min) + tμ(v_max)], B' = c_b·B;
//   H_top = α_top(β_top·σB + (1−β_top)H₀), H_bottom = stretch·α_bottom(β_bottom·B' + (1−β_bottom)H₀),
//     B scaled by σ (metres) on top so both terms are lengths: for a disc of
//     radius R, σB and B' are both the hemisphere of radius R;
//   the basemaps smoothed across rows (our addition: where a row's span jumps,
//     at a bay or a lobe, the per-row formula makes walls and stripes);
//   the bottom kept at least rim_m under the top; a middle strip joins the two rims.
// Units: metres, +Y up, x = column, z = row, centred on the canvas.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reefgen/mesh.hpp"
#include "reefgen/params_json.hpp"

namespace reefgen::islands {

struct FloatingParams {
  double alpha_top = 0.2;       // α_top: overall scale of the top surface, [0, 100]
  double beta_top = 0.2;        // β_top: basemap (dome) vs features H₀ on top, [-10, 10]
  double alpha_bottom = 0.8;    // α_bottom: overall scale of the bottom, [0, 100]
  double beta_bottom = -2.5;    // β_bottom: negative hangs the rock down, [-10, 10]
  double depth_stretch = 1.5;   // multiplies the bottom, (0, 100]
  double metres_per_px = 1.0;   // ground size of a painting pixel, (0, 1e4]
  double feature_m = 5.0;       // amplitude of the noise H₀ when no terrain is given, [0, 1e4]
  double feature_px = 48.0;     // size of the noise's largest features, pixels, [1, 1e4]
  int octaves = 5;              // noise octaves, [1, 10]
  double simplify_px = 1.0;     // Douglas–Peucker tolerance of the silhouette, pixels, [0, 16]
  double smooth_px = 4.0;       // Gaussian σ smoothing the basemaps across rows (ours: per-row spans jump), [0, 64]
  double rim_m = 2.0;           // least thickness at the rim (the middle strip's height), (0, 1e4]
  int min_area_px = 16;         // painted top blobs smaller than this are ignored, [1, 1e8]
  // Palette: every pixel takes the class of the nearest of these colours
  // (RGB distance); transparent pixels (alpha < 128) are background.
  std::vector<std::string> top_colours = {"#4caf50", "#ffffff"};         // green, snow
  std::vector<std::string> bottom_colours = {"#8b5a2b"};                 // brown rock
  std::vector<std::string> background_colours = {"#87ceeb", "#000000"};  // sky, black
};
template <class F>
void fields(FloatingParams& p, F&& f) {  // the one field list (common/params_json.hpp)
  f("alpha_top", p.alpha_top, Range{0, 100});
  f("beta_top", p.beta_top, Range{-10, 10});
  f("alpha_bottom", p.alpha_bottom, Range{0, 100});
  f("beta_bottom", p.beta_bottom, Range{-10, 10});
  f("depth_stretch", p.depth_stretch, Range{1e-3, 100});  // below, vertices merge in float32
  f("metres_per_px", p.metres_per_px, Range{1e-3, 1e4});
  f("feature_m", p.feature_m, Range{0, 1e4});
  f("feature_px", p.feature_px, Range{1, 1e4});
  f("octaves", p.octaves, Range{1, 10});
  f("simplify_px", p.simplify_px, Range{0, 16});
  f("smooth_px", p.smooth_px, Range{0, 64});
  f("rim_m", p.rim_m, Range{1e-3, 1e4});
  f("min_area_px", p.min_area_px, Range{1, 1e8});
  f("top_colours", p.top_colours);
  f("bottom_colours", p.bottom_colours);
  f("background_colours", p.background_colours);
}
// Throws reefgen::Error naming the field and its range.
void validate(const FloatingParams& p);
nlohmann::json to_json(const FloatingParams& p);
// Strict: unknown keys and wrong types name `origin` and the key.
FloatingParams floating_params_from_json(const nlohmann::json& j, const std::string& origin);

enum PaintClass : uint8_t { kPaintBackground = 0, kPaintTop = 1, kPaintBottom = 2 };
// Segments an 8- or 16-bit BGR/BGRA/grey image by the palette. Throws
// reefgen::Error naming `origin` when there is no top, or when a top colour
// covers most of the border (a white canvas read as snow).
// When `top_rgb` is given, it receives per pixel the linear RGB of the top
// colour the pixel was assigned to (zero elsewhere): snow stays white on the mesh.
cv::Mat1b segment_painting(const cv::Mat& image, const FloatingParams& p, const std::string& origin,
                           cv::Mat3f* top_rgb = nullptr);

// Noise features H₀ ∈ [0, feature_m] (metres) of the given size.
cv::Mat1f floating_features(cv::Size size, const FloatingParams& p, uint64_t seed);

// A painting shrunk (area averaging: edges become blends, which the
// segmentation assigns) so its long side is at most max_px (0 = as painted);
// p's pixel sizes follow so the island keeps its ground size and look.
cv::Mat shrink_painting(const cv::Mat& image, int max_px, FloatingParams& p);

// A height field's land (h > 0) as the top (labels kPaintTop) and its relief
// as the features H₀. Throws reefgen::Error naming `origin` for NaN or
// infinite heights, heights beyond ±100 km (not metres), or no land.
struct HeightTop {
  cv::Mat1b labels;
  cv::Mat1f h0_m;
};
HeightTop top_of_height_field(const cv::Mat1f& height_m, const std::string& origin);
void check_floating_heights(const cv::Mat1f& height_m, const std::string& origin);

// Basemaps of one blob (mask of its pixels) at pixel centres: B (unitless,
// [0, 1]), σ·B and B' (metres, B' ≥ 0: c_b clamped at 0); 0 outside the blob's rows' spans.
struct Basemaps {
  cv::Mat1f b, top_m, bottom_m;
};
Basemaps floating_basemaps(const cv::Mat1b& blob, double metres_per_px);

struct FloatingIsland {
  Mesh mesh;              // closed, outward-wound, one shell per blob; vertex colours
                          // (painted top colours, rock); uvs drape the painting (top view) over it
  int islands = 0;        // shells
  double top_max_m = 0;   // highest top point
  double depth_m = 0;     // deepest bottom point (positive)
  cv::Mat1f top_m, bottom_m;  // per pixel of the canvas; NaN off the islands
};
// `labels` from segment_painting (or any mask: kPaintTop where the top is);
// `h0_m` the features (same size). Throws reefgen::Error if no blob is big enough.
// `top_rgb` (optional, from segment_painting) colours the top's vertices;
// without it the top is the first top colour. The rock is the first bottom colour.
FloatingIsland floating_island(const cv::Mat1b& labels, const cv::Mat1f& h0_m, const FloatingParams& p,
                               const cv::Mat3f& top_rgb = cv::Mat3f());

// The mesh seen from above, rasterised at the canvas' pixel centres (255 = covered).
cv::Mat1b mesh_silhouette(const Mesh& m, cv::Size canvas, double metres_per_px);
double mask_iou(const cv::Mat1b& a, const cv::Mat1b& b);

// A shaded oblique view of the mesh (BGR), for previews and docs.
cv::Mat3b render_mesh(const Mesh& m, int width_px, double yaw_deg = 30, double pitch_deg = 25);

// One `reefgen floating` run: where the top comes from and which files to write.
struct FloatingJob {
  std::string painting;            // painting file: its top colours are the top ("" = none)
  std::string height_exr;          // height field EXR (metres): its land is the top, or the
                                   // features under the painting ("" = noise features)
  uint64_t seed = 1;               // noise features' seed
  int max_size_px = 0;             // painting shrunk to this long side, px; 0 = as painted
  std::optional<double> metres_per_px;  // overrides the params and the EXR's own pixel size, m
  std::vector<std::string> meshes;  // .glb / .obj files; the .json sidecar goes beside the first
  std::string preview_png;         // shaded oblique view, "" = none
  std::string preset;              // recorded in the sidecar
  std::string config;              // params file p came from ("" = none): refused as an output
};
// Builds the island, refuses a mesh that is not closed, and writes the meshes,
// the preview and the sidecar all or nothing (nothing is touched on failure; an
// output that is an input, or one named twice, is refused first). With a
// height field alone, the pixel size is the EXR's own or reefgen's 6 km canvas.
// Returns the sidecar. Throws reefgen::Error naming the file at fault.
nlohmann::json make_floating(const FloatingJob& job, FloatingParams p);

}  // namespace reefgen::islands
