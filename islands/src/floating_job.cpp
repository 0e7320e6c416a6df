// make_floating: a floating island from files to files (the `floating` command).
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/io.hpp"
#include "reefgen/islands/floating.hpp"
#include "reefgen/mesh.hpp"
#include "reefgen/version.hpp"

namespace reefgen::islands {

namespace {
void check_outputs(const FloatingJob& job, const fs::path& sidecar) {
  if (job.painting.empty() && job.height_exr.empty())
    throw Error("floating: give --painting FILE or --height H.exr (see reefgen floating --help)");
  if (job.meshes.empty()) throw Error("floating: give -o FILE.glb or -o FILE.obj");
  for (const auto& o : job.meshes) {
    const std::string ext = fs::path(o).extension().string();
    if (ext != ".glb" && ext != ".obj") throw Error("-o " + o + ": the mesh file must end in .glb or .obj");
  }
  std::vector<fs::path> ins, outs(job.meshes.begin(), job.meshes.end());
  for (const auto& i : {job.painting, job.height_exr, job.config})
    if (!i.empty()) ins.push_back(i);
  if (!job.preview_png.empty()) outs.push_back(job.preview_png);
  outs.push_back(sidecar);
  refuse_output_over_input(ins, outs);
  for (size_t i = 0; i < outs.size(); ++i)
    for (size_t k = i + 1; k < outs.size(); ++k)
      if (outs[i].lexically_normal() == outs[k].lexically_normal())
        throw Error(outs[i].string() + ": named twice as an output; give each output its own name");
}
}  // namespace

// Long: the job's steps in order (read, shape, check the mesh, stage every
// file, commit), each marked; the staged set spans all of them.
nlohmann::json make_floating(const FloatingJob& job, FloatingParams p) {
  const fs::path sidecar = job.meshes.empty() ? fs::path() : fs::path(job.meshes.front()).replace_extension(".json");
  check_outputs(job, sidecar);

  // The top silhouette (labels), its painted colours (snow stays white on the
  // mesh) and the features H₀.
  cv::Mat1b labels;
  cv::Mat3f top_rgb;
  cv::Mat1f h0, terrain;
  if (!job.height_exr.empty()) {
    ExrAttributes attrs;
    terrain = read_exr_height(job.height_exr, &attrs);
    if (job.painting.empty()) {  // the terrain is the canvas: its pixel size, or reefgen's 6 km across
      const double mpp = exr_metres_per_px(attrs);
      p.metres_per_px = mpp > 0 ? mpp : kCanvasWorldSizeM / terrain.cols;
    }
    check_floating_heights(terrain, job.height_exr);
  }
  if (job.metres_per_px) p.metres_per_px = *job.metres_per_px;
  validate(p);
  if (!job.painting.empty()) {
    if (!fs::is_regular_file(job.painting)) throw Error(job.painting + ": no such file (check the path)");
    const cv::Mat img = shrink_painting(read_image(job.painting, cv::IMREAD_UNCHANGED), job.max_size_px, p);
    labels = segment_painting(img, p, job.painting, &top_rgb);
    if (terrain.empty())
      h0 = floating_features(labels.size(), p, job.seed);
    else  // the terrain's land relief under the painted outline
      cv::resize(cv::max(terrain, 0.f), h0, labels.size(), 0, 0, cv::INTER_LINEAR);
  } else {
    HeightTop top = top_of_height_field(terrain, job.height_exr);
    labels = top.labels;
    h0 = top.h0_m;
  }
  const std::string source = job.painting.empty() ? job.height_exr : job.painting;
  FloatingIsland isl;
  try {
    isl = floating_island(labels, h0, p, top_rgb);
  } catch (const Error& e) {
    throw Error(source + ": " + e.what());
  }
  // What Blender will be handed: refuse rather than write a broken mesh.
  const MeshReport rep = inspect_mesh(isl.mesh);
  if (!rep.closed_manifold())
    throw Error(source + ": internal error: the mesh is not closed (" + std::to_string(rep.open_edges) +
                " open edges, " + std::to_string(rep.degenerate) + " degenerate triangles); please report it");
  const double iou = mask_iou(mesh_silhouette(isl.mesh, labels.size(), p.metres_per_px), labels == kPaintTop);

  // Staged, renamed into place together: a failure (an output that is a
  // folder, a full disk) leaves earlier files as they were.
  StagedOutputs staged;
  for (const auto& o : job.meshes) {
    const fs::path path(o);
    ensure_writable_dir(path.has_parent_path() ? path.parent_path() : fs::path("."));
    staged.write(path, [&](const fs::path& t) {
      if (path.extension() == ".obj")
        write_obj(t, isl.mesh, "reefgen floating island: metres, +Y up, closed 2-manifold");
      else
        write_glb(t, isl.mesh, "floating-island");
    });
  }
  if (!job.preview_png.empty()) {
    const fs::path path(job.preview_png);
    ensure_writable_dir(path.has_parent_path() ? path.parent_path() : fs::path("."));
    staged.write(path, [&](const fs::path& t) { write_png(t, render_mesh(isl.mesh, 768)); });
  }
  const nlohmann::json side = {
      {"reefgen_version", kVersion},
      {"source", fs::absolute(source).string()},
      {"features", terrain.empty() ? "noise" : fs::absolute(job.height_exr).string()},
      {"seed", job.seed},
      {"preset", job.preset},
      {"params", to_json(p)},
      {"mesh", {{"files", job.meshes}, {"units", "metres"}, {"up", "+Y"},
                {"vertices", isl.mesh.positions.size()}, {"triangles", isl.mesh.triangles.size()},
                {"shells", isl.islands}, {"closed_2_manifold", true}, {"volume_m3", rep.volume_m3}}},
      {"top_max_m", isl.top_max_m},
      {"depth_m", isl.depth_m},
      {"silhouette_iou", iou}};
  staged.write(sidecar, [&](const fs::path& t) { write_json_atomic(t, side); });  // last
  staged.commit();
  return side;
}

}  // namespace reefgen::islands
