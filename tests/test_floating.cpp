// Floating islands from a painting: segmentation, basemaps, closed meshes,
// silhouettes, exports read back; and the mesh inspection itself.
#include <limits>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/io.hpp"
#include "reefgen/mesh.hpp"
#include "reefgen/islands/floating.hpp"
#include "test_util.hpp"

using namespace reefgen;
using namespace reefgen::islands;
using test::expect_error_naming;
using test::temp_dir;

namespace {

const cv::Scalar kGreen(80, 175, 76), kBrown(43, 90, 139), kWhite(255, 255, 255);  // BGR

// A painted floating island: an irregular green top with a snow patch, brown
// rock hanging about `rock_px` below its lowest row, anti-aliased edges, sky around.
cv::Mat3b painting(int W = 128, int rock_px = 30) {
  cv::Mat3b img(W, W, cv::Vec3b(235, 206, 135));
  const cv::Point c(W / 2, W / 3);
  cv::ellipse(img, c + cv::Point(0, W / 10), cv::Size(W / 5, W / 6 + rock_px), 0, 0, 180, kBrown, cv::FILLED, cv::LINE_AA);
  cv::ellipse(img, c, cv::Size(W * 3 / 8, W / 5), 10, 0, 360, kGreen, cv::FILLED, cv::LINE_AA);
  cv::circle(img, c + cv::Point(W / 4, W / 8), W / 8, kGreen, cv::FILLED, cv::LINE_AA);
  cv::circle(img, c + cv::Point(-W / 10, -W / 40), W / 16, kWhite, cv::FILLED, cv::LINE_AA);
  return img;
}

cv::Mat1b top_mask(const cv::Mat1b& labels) { return labels == kPaintTop; }

void expect_closed(const Mesh& m) {
  const MeshReport r = inspect_mesh(m);
  EXPECT_EQ(r.open_edges, 0u);
  EXPECT_EQ(r.nonmanifold_edges, 0u);
  EXPECT_EQ(r.misoriented_edges, 0u);
  EXPECT_EQ(r.degenerate, 0u);
  EXPECT_EQ(r.nonmanifold_vertices, 0u);
  EXPECT_GT(r.volume_m3, 0.0) << "wound inwards";
}

}  // namespace

TEST(MeshInspect, FindsEveryDefect) {
  // A tetrahedron, wound outwards.
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  MeshReport r = inspect_mesh(m);
  EXPECT_TRUE(r.closed_manifold());
  EXPECT_NEAR(r.volume_m3, 1.0 / 6, 1e-9);
  Mesh open = m;
  open.triangles.pop_back();
  EXPECT_EQ(inspect_mesh(open).open_edges, 3u);
  Mesh flipped = m;
  std::swap(flipped.triangles[0][1], flipped.triangles[0][2]);
  EXPECT_EQ(inspect_mesh(flipped).misoriented_edges, 3u);
  Mesh doubled = m;
  doubled.triangles.push_back(m.triangles[0]);
  EXPECT_EQ(inspect_mesh(doubled).nonmanifold_edges, 3u);
  Mesh flat = m;
  flat.positions[3] = {0.5f, 0.5f, 0};  // apex in the plane of the base: face 1,2,3 has zero area
  EXPECT_GE(inspect_mesh(flat).degenerate, 1u);
  // Two tetrahedra sharing only a vertex: every edge fine, the vertex pinched.
  Mesh pinch = m;
  for (int k = 1; k < 4; ++k) pinch.positions.push_back(-m.positions[size_t(k)]);
  pinch.triangles.push_back({0, 4, 5});
  pinch.triangles.push_back({0, 6, 4});
  pinch.triangles.push_back({0, 5, 6});
  pinch.triangles.push_back({4, 6, 5});
  r = inspect_mesh(pinch);
  EXPECT_EQ(r.open_edges + r.nonmanifold_edges + r.misoriented_edges, 0u);
  EXPECT_EQ(r.nonmanifold_vertices, 1u);
}

TEST(Floating, SegmentsByPalette) {
  const cv::Mat3b img = painting();
  const cv::Mat1b lab = segment_painting(img, {}, "p.png");
  EXPECT_EQ(lab(128 / 3, 64), kPaintTop);         // centre of the top
  EXPECT_EQ(lab(128 / 3 - 3, 64 - 13), kPaintTop);  // snow counts as top
  EXPECT_EQ(lab(128 / 3 + 12 + 25, 64), kPaintBottom);
  EXPECT_EQ(lab(2, 2), kPaintBackground);
  // Anti-aliased edge pixels take the nearest class: no fourth value, and
  // brown–sky blends never become top (nearer to green than to either).
  for (auto v : lab) EXPECT_LE(v, kPaintBottom);
  cv::Mat1i ids;
  EXPECT_EQ(cv::connectedComponents(lab == kPaintTop, ids, 8), 2) << "one top blob and the background";
  // Transparent pixels are background whatever their colour.
  cv::Mat4b rgba;
  cv::cvtColor(img, rgba, cv::COLOR_BGR2BGRA);
  rgba(128 / 3, 64)[3] = 0;
  EXPECT_EQ(segment_painting(rgba, {}, "p.png")(128 / 3, 64), kPaintBackground);
  // 16-bit images are read too.
  cv::Mat img16;
  img.convertTo(img16, CV_16U, 257);
  EXPECT_EQ(cv::countNonZero(segment_painting(img16, {}, "p.png") != lab), 0);
}

TEST(Floating, SegmentationErrorsNameTheFileAndTheFix) {
  expect_error_naming([] { segment_painting(cv::Mat3b(32, 32, cv::Vec3b(235, 206, 135)), {}, "sky.png"); },
                      "sky.png: no pixel is nearest to a top colour");
  cv::Mat3b white(64, 64, cv::Vec3b(255, 255, 255));
  cv::circle(white, {32, 32}, 10, kGreen, cv::FILLED);
  expect_error_naming([&] { segment_painting(white, {}, "white.png"); }, "white canvas");
  FloatingParams p;
  p.top_colours = {"green"};
  expect_error_naming([&] { segment_painting(painting(), p, "p.png"); }, "\"green\" is not of the form #rrggbb");
}

TEST(Floating, BasemapsOfADiscAreHemispheres) {
  cv::Mat1b disc(81, 81, uchar(0));
  cv::circle(disc, {40, 40}, 30, cv::Scalar(255), cv::FILLED);
  const Basemaps b = floating_basemaps(disc, 2.0);
  EXPECT_NEAR(b.b(40, 40), 1.0, 1e-6);
  EXPECT_NEAR(b.top_m(40, 40), 30.5 * 2.0, 1e-4);  // σ reaches the pixels' outer edges
  EXPECT_EQ(b.b(5, 40), 0.f);                        // outside the blob's rows
  EXPECT_EQ(b.b(40, 5), 0.f);                        // outside the row's span
  for (int r = 12; r <= 68; r += 7)
    for (int c = 12; c <= 68; c += 7) {
      // Symmetric shape: c_b = σ(v), so B' = σB = √(σ² − (u − μ)²) on every row.
      EXPECT_NEAR(b.bottom_m(r, c), b.top_m(r, c), 1e-3) << r << "," << c;
      if (b.b(r, c) > 0) {
        const double s = b.top_m(r, 40) / 2.0;  // the row's σ in pixels
        EXPECT_NEAR(b.top_m(r, c), 2.0 * std::sqrt(std::max(0.0, s * s - (c - 40.0) * (c - 40.0))), 1e-3);
      }
    }
  // A shape leaning right below its axis: the rock's tip moves under the bulge.
  cv::Mat1b lean(81, 81, uchar(0));
  cv::rectangle(lean, {20, 10}, {40, 40}, cv::Scalar(255), cv::FILLED);
  cv::rectangle(lean, {20, 41}, {60, 50}, cv::Scalar(255), cv::FILLED);
  cv::rectangle(lean, {20, 51}, {40, 70}, cv::Scalar(255), cv::FILLED);
  const Basemaps l = floating_basemaps(lean, 1.0);
  EXPECT_GT(l.bottom_m(45, 40), l.bottom_m(25, 30) * 1.5);
}

TEST(Floating, DiscMeshMatchesTheFormulas) {
  // No features: the top is the dome α_t·β_t·σB and the bottom reaches
  // stretch·α_b·|β_b|·R under the centre.
  cv::Mat1b lab(129, 129, uchar(0));
  cv::circle(lab, {64, 64}, 40, cv::Scalar(kPaintTop), cv::FILLED);
  FloatingParams p;
  p.metres_per_px = 2.0;
  p.simplify_px = 0;  // the polygon keeps every boundary pixel: σ = 40.5 px on the middle row
  p.smooth_px = 0;    // the formulas as written
  const FloatingIsland isl = floating_island(lab, cv::Mat1f(lab.size(), 0.f), p);
  const double R = 40.5 * 2.0;
  EXPECT_EQ(isl.islands, 1);
  EXPECT_NEAR(isl.top_max_m, 0.2 * 0.2 * R, 1e-3);
  EXPECT_NEAR(isl.depth_m, 1.5 * 0.8 * 2.5 * R, 1e-2);
  EXPECT_NEAR(isl.bottom_m(64, 64), -1.5 * 0.8 * 2.5 * R, 1e-2);
  expect_closed(isl.mesh);
  // Volume of a half-ellipsoid pair: (2/3)πR²(top + depth); the grid's chords
  // cut the steep profile at the rim (observed −3.7 %).
  const double v = 2.0 / 3.0 * CV_PI * R * R * (0.04 * R + 3.0 * R);
  EXPECT_NEAR(inspect_mesh(isl.mesh).volume_m3 / v, 1.0, 0.05);
  EXPECT_GE(mask_iou(mesh_silhouette(isl.mesh, lab.size(), 2.0), top_mask(lab) * 255), 0.97);
}

TEST(Floating, PaintingGivesAClosedShellWithThePaintedSilhouette) {
  const cv::Mat1b lab = segment_painting(painting(), {}, "p.png");
  FloatingParams p;
  const FloatingIsland isl = floating_island(lab, floating_features(lab.size(), p, 7), p);
  EXPECT_EQ(isl.islands, 1);
  expect_closed(isl.mesh);
  const double iou = mask_iou(mesh_silhouette(isl.mesh, lab.size(), p.metres_per_px), top_mask(lab));
  EXPECT_GE(iou, 0.95);
  // The tip is as deep as the painted rock reaches under the top's lowest row.
  int last_top = 0, last_rock = 0;
  for (int r = 0; r < lab.rows; ++r) {
    if (cv::countNonZero(lab.row(r) == kPaintTop)) last_top = r;
    if (cv::countNonZero(lab.row(r) == kPaintBottom)) last_rock = r;
  }
  ASSERT_GT(last_rock, last_top + 10);
  EXPECT_NEAR(isl.depth_m, (last_rock - last_top) * p.metres_per_px, 1e-3);
  // The bottom is never closer than the rim thickness to the top.
  for (int r = 0; r < lab.rows; ++r)
    for (int c = 0; c < lab.cols; ++c)
      if (!std::isnan(isl.top_m(r, c))) {
        ASSERT_GE(isl.top_m(r, c) - isl.bottom_m(r, c), p.rim_m - 1e-4);
      }
}

TEST(Floating, ClosedForHardShapes) {
  // Several blobs, a concave C touching the canvas edge, thin necks, diagonal
  // pixel contacts, tiny specks (ignored), at several simplifications.
  cv::Mat1b lab(96, 96, uchar(0));
  cv::ellipse(lab, {0, 48}, {30, 30}, 0, -80, 80, cv::Scalar(kPaintTop), 9);  // C cut by the left edge
  cv::circle(lab, {70, 20}, 12, cv::Scalar(kPaintTop), cv::FILLED);
  cv::line(lab, {70, 20}, {85, 60}, cv::Scalar(kPaintTop), 2);  // thin neck
  cv::circle(lab, {85, 70}, 10, cv::Scalar(kPaintTop), cv::FILLED);
  for (int k = 0; k < 6; ++k) lab(40 + k, 50 + k) = kPaintTop;  // a diagonal staircase (under min area)
  lab(90, 10) = kPaintTop;                                       // a speck
  for (double simplify : {0.0, 1.0, 3.0}) {
    FloatingParams p;
    p.simplify_px = simplify;
    const FloatingIsland isl = floating_island(lab, floating_features(lab.size(), p, 3), p);
    SCOPED_TRACE("simplify_px " + std::to_string(simplify));
    EXPECT_EQ(isl.islands, 2);
    expect_closed(isl.mesh);
    if (simplify <= 1.0) {  // thin shapes: a 2 px neck, a 9 px band
      EXPECT_GE(mask_iou(mesh_silhouette(isl.mesh, lab.size(), 1.0), lab == kPaintTop), 0.93);
    }
  }
  // Random blobs: thresholded noise, many seeds.
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    FloatingParams p;
    p.feature_px = 12;
    const cv::Mat1f n = floating_features({80, 80}, p, seed);
    cv::Mat1b blobs = (n > 0.55f * float(p.feature_m)) / 255 * kPaintTop;
    SCOPED_TRACE("seed " + std::to_string(seed));
    if (cv::countNonZero(blobs) < 16) continue;
    const FloatingIsland isl = floating_island(blobs, n, p);
    expect_closed(isl.mesh);
  }
}

TEST(Floating, DeterministicWithGoldenFigures) {
  const cv::Mat1b lab = segment_painting(painting(), {}, "p.png");
  FloatingParams p;
  const FloatingIsland a = floating_island(lab, floating_features(lab.size(), p, 11), p);
  const FloatingIsland b = floating_island(lab, floating_features(lab.size(), p, 11), p);
  ASSERT_EQ(a.mesh.positions.size(), b.mesh.positions.size());
  EXPECT_EQ(0, std::memcmp(a.mesh.positions.data(), b.mesh.positions.data(), a.mesh.positions.size() * 12));
  EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
  const FloatingIsland c = floating_island(lab, floating_features(lab.size(), p, 12), p);
  EXPECT_NE(a.top_max_m, c.top_max_m);
  // Golden figures (recorded when written, looked at in a render): a closed
  // genus-0 shell has V = F/2 + 2.
  EXPECT_EQ(a.mesh.positions.size(), 8942u);
  EXPECT_EQ(a.mesh.triangles.size(), 17880u);
  EXPECT_NEAR(a.top_max_m, 2.1103, 1e-3);
  EXPECT_NEAR(a.depth_m, 31.0, 1e-3);
}

TEST(Floating, ObjAndGlbReadBackClosed) {
  const fs::path d = temp_dir("floating");
  const cv::Mat1b lab = segment_painting(painting(64, 15), {}, "p.png");
  FloatingParams p;
  const FloatingIsland isl = floating_island(lab, floating_features(lab.size(), p, 5), p);
  write_obj(d / "f.obj", isl.mesh, "test");
  write_glb(d / "f.glb", isl.mesh, "floating");
  for (const Mesh& back : {read_obj(d / "f.obj"), read_glb(d / "f.glb")}) {
    ASSERT_EQ(back.positions.size(), isl.mesh.positions.size());
    EXPECT_EQ(back.triangles, isl.mesh.triangles);
    for (size_t i = 0; i < back.positions.size(); i += 7)
      EXPECT_LE(cv::norm(back.positions[i] - isl.mesh.positions[i]), 1e-3);
    expect_closed(back);
  }
  const Mesh glb = read_glb(d / "f.glb");
  ASSERT_EQ(glb.normals.size(), glb.positions.size());
  // Colours and texture coordinates survive both formats.
  const Mesh obj = read_obj(d / "f.obj");
  ASSERT_EQ(glb.colors.size(), glb.positions.size());
  ASSERT_EQ(obj.uvs.size(), glb.positions.size());
  for (size_t i = 0; i < glb.positions.size(); i += 5) {
    EXPECT_EQ(glb.colors[i], isl.mesh.colors[i]);
    EXPECT_LE(cv::norm(obj.colors[i] - isl.mesh.colors[i]), 1e-4);
    EXPECT_EQ(glb.uvs[i], isl.mesh.uvs[i]);
    EXPECT_LE(cv::norm(obj.uvs[i] - isl.mesh.uvs[i]), 1e-4);
    // The uv is where the vertex lies on the painting (u = column, v = row, in [0, 1]).
    EXPECT_NEAR(isl.mesh.uvs[i][0], (isl.mesh.positions[i][0] / p.metres_per_px + lab.cols / 2.0) / lab.cols, 1e-5);
  }
  // Top faces are grass, bottom faces rock.
  for (const auto& t : isl.mesh.triangles) {
    const cv::Vec3f a = isl.mesh.positions[t[0]], n = (isl.mesh.positions[t[1]] - a).cross(isl.mesh.positions[t[2]] - a);
    if (n[1] > 0.9f * cv::norm(n)) {
      EXPECT_GT(isl.mesh.colors[t[0]][1], 0.3f);  // green
    }
    if (n[1] < -0.9f * cv::norm(n)) {
      EXPECT_LT(isl.mesh.colors[t[0]][1], 0.2f);  // brown
    }
  }
  for (const auto& n : glb.normals) EXPECT_NEAR(cv::norm(n), 1.0, 1e-4);
  // Corrupt files: one error naming the file.
  write_text_atomic(d / "bad.glb", "glTF but not really");
  expect_error_naming([&] { read_glb(d / "bad.glb"); }, "bad.glb");
  write_text_atomic(d / "bad.obj", "v 1 2 3\nv 1 2 4\nv 1 3 3\nf 1 2 9\n");
  expect_error_naming([&] { read_obj(d / "bad.obj"); }, "bad.obj:4: face index 9 out of range");
  fs::remove_all(d);
}

TEST(Floating, ParamsJsonRoundTripAndErrors) {
  FloatingParams p;
  p.alpha_top = 0.5;
  p.top_colours = {"#00ff00"};
  const FloatingParams q = floating_params_from_json(to_json(p), "x.json");
  EXPECT_EQ(to_json(q), to_json(p));
  expect_error_naming([] { floating_params_from_json({{"alpha_tpo", 1}}, "x.json"); }, "x.json: unknown key \"alpha_tpo\"");
  expect_error_naming([] { floating_params_from_json({{"rim_m", 0}}, "x.json"); }, "rim_m");
  expect_error_naming([] { floating_params_from_json({{"octaves", "five"}}, "x.json"); }, "octaves = \"five\" must be a whole number");
  cv::Mat1b speck(16, 16, uchar(0));
  speck(cv::Rect(5, 5, 3, 3)) = kPaintTop;
  expect_error_naming([&] { floating_island(speck, cv::Mat1f(16, 16, 0.f), {}); }, "lower min_area_px");
}

TEST(Floating, PresetsAreSerialisedParamsAndAllClose) {
  const fs::path dir = fs::path(REEFGEN_SOURCE_DIR) / "configs" / "floating";
  EXPECT_EQ(read_json(dir / "default.json"), to_json(FloatingParams{})) << "default.json must be the defaults serialised";
  const cv::Mat img = cv::imread((fs::path(REEFGEN_SOURCE_DIR) / "docs/examples/floating-painting.png").string());
  ASSERT_FALSE(img.empty());
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    const FloatingParams p = floating_params_from_json(read_json(e.path()), e.path().string());
    EXPECT_EQ(to_json(p), read_json(e.path())) << e.path() << " must list every field";
    const cv::Mat1b lab = segment_painting(img, p, "example");
    const FloatingIsland isl = floating_island(lab, floating_features(lab.size(), p, 1), p);
    SCOPED_TRACE(e.path().string());
    expect_closed(isl.mesh);
    EXPECT_GE(mask_iou(mesh_silhouette(isl.mesh, lab.size(), p.metres_per_px), lab == kPaintTop), 0.95);
    ++n;
  }
  EXPECT_GE(n, 4);
}

TEST(Floating, SmoothingRemovesRowSteps) {
  // A blob whose row spans jump (a lobe): without smoothing, the bottom steps
  // between rows; smoothed, the largest row-to-row step is much smaller.
  cv::Mat1b lab(96, 96, uchar(0));
  cv::rectangle(lab, {20, 10}, {50, 80}, cv::Scalar(kPaintTop), cv::FILLED);
  cv::rectangle(lab, {20, 40}, {80, 55}, cv::Scalar(kPaintTop), cv::FILLED);
  auto max_step = [&](double smooth) {
    FloatingParams p;
    p.smooth_px = smooth;
    p.feature_m = 0;
    const FloatingIsland isl = floating_island(lab, cv::Mat1f(lab.size(), 0.f), p);
    expect_closed(isl.mesh);
    double m = 0;
    for (int r = 5; r + 1 < 90; ++r)
      for (int c = 25; c <= 45; ++c)
        if (!std::isnan(isl.bottom_m(r, c)) && !std::isnan(isl.bottom_m(r + 1, c)))
          m = std::max(m, double(std::abs(isl.bottom_m(r + 1, c) - isl.bottom_m(r, c))));
    return m;
  };
  const double raw = max_step(0), smooth = max_step(4);
  EXPECT_GT(raw, 10.0);
  EXPECT_LT(smooth, raw / 3);
}

TEST(Floating, PaintedTopColoursReachTheMesh) {
  // Snow painted white stays white on the top; green stays green; rock below.
  cv::Mat3f rgb;
  const cv::Mat1b lab = segment_painting(painting(), {}, "p.png", &rgb);
  FloatingParams p;
  const FloatingIsland isl = floating_island(lab, floating_features(lab.size(), p, 7), p, rgb);
  auto colour_near = [&](double col, double row, bool top) {  // colour of the top (or bottom) vertex nearest a pixel
    const cv::Vec3f at(float((col - 63.5) * p.metres_per_px), 0, float((row - 63.5) * p.metres_per_px));
    double best = 1e30;
    cv::Vec3f c;
    for (size_t i = 0; i < isl.mesh.positions.size(); ++i) {
      const cv::Vec3f& v = isl.mesh.positions[i];
      if ((v[1] > -p.rim_m / 2) != top) continue;  // top vertices sit above the rim plane's neighbourhood
      const double d = std::hypot(v[0] - at[0], v[2] - at[2]);
      if (d < best) best = d, c = isl.mesh.colors[i];
    }
    return c;
  };
  const cv::Vec3f snow = colour_near(52, 39, true), grass = colour_near(84, 45, true), rock = colour_near(64, 45, false);
  EXPECT_GT(snow[0], 0.9f);
  EXPECT_GT(snow[2], 0.9f);
  EXPECT_NEAR(grass[1], 0.434f, 0.01f);  // #4caf50 in linear RGB
  EXPECT_LT(grass[0], 0.1f);
  EXPECT_NEAR(rock[0], 0.258f, 0.01f);  // #8b5a2b in linear RGB
}

// The CLI's painting and height-field handling, now library functions: a
// shrunk painting keeps its ground size, a height field's land is the top,
// and bad fields are refused naming the file.
TEST(Floating, ShrinkPaintingAndTopOfHeightField) {
  FloatingParams p;
  p.metres_per_px = 2.0;
  p.feature_px = 40;
  const cv::Mat img(400, 200, CV_8UC3, cv::Scalar(0, 200, 0));
  const cv::Mat small = shrink_painting(img, 100, p);
  EXPECT_EQ(small.rows, 100);
  EXPECT_EQ(small.cols, 50);
  EXPECT_DOUBLE_EQ(p.metres_per_px * small.cols, 2.0 * 200);  // same ground width
  EXPECT_DOUBLE_EQ(p.feature_px, 10.0);
  EXPECT_EQ(shrink_painting(img, 0, p).cols, 200);  // 0 = as painted
  EXPECT_EQ(shrink_painting(img, 500, p).cols, 200);
  expect_error_naming([&] { shrink_painting(img, -1, p); }, "max-size");

  cv::Mat1f h(8, 8, -5.f);
  h(3, 4) = 12.f;
  h(4, 4) = 3.f;
  const HeightTop t = top_of_height_field(h, "f.exr");
  EXPECT_EQ(cv::countNonZero(t.labels == kPaintTop), 2);
  EXPECT_FLOAT_EQ(t.h0_m(3, 4), 12.f);
  EXPECT_FLOAT_EQ(t.h0_m(0, 0), 0.f);
  expect_error_naming([&] { top_of_height_field(cv::Mat1f(8, 8, -1.f), "sea.exr"); }, "sea.exr: no land");
  h(0, 0) = std::numeric_limits<float>::quiet_NaN();
  expect_error_naming([&] { top_of_height_field(h, "nan.exr"); }, "nan.exr");
  h(0, 0) = 2e5f;
  expect_error_naming([&] { top_of_height_field(h, "km.exr"); }, "100 km");
}

TEST(Floating, ParamsRoundTripEveryField) {
  test::expect_params_round_trip<FloatingParams>(
      [](const nlohmann::json& j) { return floating_params_from_json(j, "f.json"); });
  expect_error_naming([] { floating_params_from_json(nlohmann::json{{"rim_m", 0}}, "f.json"); },
                      "f.json: rim_m = 0 is out of range; expected [0.001, 10000]");
}

// The whole command as a library call: files in, meshes + preview + sidecar
// out, all or nothing, never over an input.
TEST(Floating, MakeFloatingWritesEverythingOrNothing) {
  const fs::path d = temp_dir("make_floating");
  write_png(d / "paint.png", painting(96, 20));
  FloatingJob job;
  job.painting = (d / "paint.png").string();
  job.seed = 3;
  job.meshes = {(d / "out/a.glb").string(), (d / "out/a.obj").string()};
  job.preview_png = (d / "out/a.preview.png").string();
  const nlohmann::json side = make_floating(job, FloatingParams{});
  for (const char* f : {"a.glb", "a.obj", "a.preview.png", "a.json"}) EXPECT_TRUE(fs::is_regular_file(d / "out" / f)) << f;
  EXPECT_EQ(side, read_json(d / "out/a.json"));
  EXPECT_TRUE(side["mesh"]["closed_2_manifold"].get<bool>());
  EXPECT_GE(side["silhouette_iou"].get<double>(), 0.9);
  expect_closed(read_glb(d / "out/a.glb"));
  const std::string glb = test::file_bytes(d / "out/a.glb");

  // The same job with another seed, but the .obj is a folder: nothing written,
  // the first run's files as they were.
  fs::remove(d / "out/a.obj");
  fs::create_directories(d / "out/a.obj");
  job.seed = 4;
  EXPECT_THROW(make_floating(job, FloatingParams{}), std::exception);
  EXPECT_EQ(test::file_bytes(d / "out/a.glb"), glb);
  EXPECT_EQ(read_json(d / "out/a.json"), side);

  // An output over an input, a name given twice, a metres_per_px out of range.
  job.meshes = {(d / "out/b.glb").string()};
  job.preview_png = job.painting;
  expect_error_naming([&] { make_floating(job, FloatingParams{}); }, "also an input");
  job.preview_png = (d / "out/b.json").string();
  expect_error_naming([&] { make_floating(job, FloatingParams{}); }, "named twice");
  job.preview_png.clear();
  job.metres_per_px = -1;
  expect_error_naming([&] { make_floating(job, FloatingParams{}); }, "metres_per_px");
  EXPECT_FALSE(fs::exists(d / "out/b.glb"));
  fs::remove_all(d);
}
