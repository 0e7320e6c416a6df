#include "reefgen/islands/floating.hpp"

#include <cstdio>

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "reefgen/params_json.hpp"
#include "reefgen/files.hpp"
#include "reefgen/terrain/noise.hpp"
#include "reefgen/rng.hpp"

namespace reefgen::islands {

using terrain::GradientNoise2;
using terrain::NoiseTile;

namespace {

cv::Vec3i parse_colour(const std::string& s) {  // "#rrggbb" → (r, g, b)
  auto hex = [&](size_t k) {
    const char c = char(std::tolower(static_cast<unsigned char>(s[k])));
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    throw Error("floating: colour \"" + s + "\" is not of the form #rrggbb");
  };
  if (s.size() != 7 || s[0] != '#') throw Error("floating: colour \"" + s + "\" is not of the form #rrggbb");
  return {hex(1) * 16 + hex(2), hex(3) * 16 + hex(4), hex(5) * 16 + hex(6)};
}

// Linear RGB of an sRGB "#rrggbb" (glTF's COLOR_0 is linear).
cv::Vec3f linear_rgb(const std::string& hex) {
  const cv::Vec3i c = parse_colour(hex);
  cv::Vec3f out;
  for (int k = 0; k < 3; ++k) {
    const double v = c[k] / 255.0;
    out[k] = float(v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4));
  }
  return out;
}

}  // namespace

void validate(const FloatingParams& p) {
  check_params(p, "floating", "configs/floating/default.json");
  if (p.top_colours.empty()) throw Error("floating: top_colours is empty (give at least one #rrggbb)");
  for (const auto* list : {&p.top_colours, &p.bottom_colours, &p.background_colours})
    for (const auto& c : *list) parse_colour(c);
}

nlohmann::json to_json(const FloatingParams& p) { return params_json(p); }

FloatingParams floating_params_from_json(const nlohmann::json& j, const std::string& origin) {
  FloatingParams p = params_from_json<FloatingParams>(j, origin, "configs/floating/");
  try {
    validate(p);
  } catch (const Error& e) {
    throw Error(origin + ": " + e.what());
  }
  return p;
}

cv::Mat1b segment_painting(const cv::Mat& image, const FloatingParams& p, const std::string& origin, cv::Mat3f* top_rgb) {
  validate(p);
  if (image.empty()) throw Error(origin + ": empty image");
  cv::Mat img8;
  if (image.depth() == CV_16U) image.convertTo(img8, CV_8U, 1.0 / 257);
  else if (image.depth() == CV_8U) img8 = image;
  else throw Error(origin + ": painting must be an 8- or 16-bit image");
  cv::Mat bgra;
  switch (img8.channels()) {
    case 1: cv::cvtColor(img8, bgra, cv::COLOR_GRAY2BGRA); break;
    case 3: cv::cvtColor(img8, bgra, cv::COLOR_BGR2BGRA); break;
    case 4: bgra = img8; break;
    default: throw Error(origin + ": painting must have 1, 3 or 4 channels");
  }
  struct Entry {
    cv::Vec3i rgb;
    uint8_t cls;
    cv::Vec3f linear;
  };
  std::vector<Entry> palette;
  for (const auto& c : p.top_colours) palette.push_back({parse_colour(c), kPaintTop, linear_rgb(c)});
  for (const auto& c : p.bottom_colours) palette.push_back({parse_colour(c), kPaintBottom, linear_rgb(c)});
  for (const auto& c : p.background_colours) palette.push_back({parse_colour(c), kPaintBackground, linear_rgb(c)});
  cv::Mat1b out(bgra.size());
  if (top_rgb) *top_rgb = cv::Mat3f(bgra.size(), cv::Vec3f(0, 0, 0));
  for (int r = 0; r < bgra.rows; ++r)
    for (int c = 0; c < bgra.cols; ++c) {
      const cv::Vec4b px = bgra.at<cv::Vec4b>(r, c);
      uint8_t cls = kPaintBackground;
      size_t chosen = 0;  // palette entry the pixel takes its class from
      if (px[3] >= 128) {
        const cv::Vec3d rgb(px[2], px[1], px[0]);
        double best = std::numeric_limits<double>::max();
        for (const auto& e : palette) {  // nearest palette colour; first listed wins ties
          const double d = cv::norm(rgb - cv::Vec3d(e.rgb), cv::NORM_L2SQR);
          if (d < best) best = d, cls = e.cls, chosen = size_t(&e - palette.data());
        }
        // Anti-aliased and soft-brush pixels are blends of two colours; a blend
        // of brown and sky can be nearer to green than to either. So blends
        // (points on the segment between two colours of different classes)
        // count too, and go to the end they are nearer to.
        for (size_t i = 0; i < palette.size(); ++i)
          for (size_t j = i + 1; j < palette.size(); ++j) {
            if (palette[i].cls == palette[j].cls) continue;
            const cv::Vec3d a(palette[i].rgb), ab = cv::Vec3d(palette[j].rgb) - a;
            const double len2 = ab.dot(ab);
            if (len2 <= 0) continue;
            const double t = std::clamp((rgb - a).dot(ab) / len2, 0.0, 1.0);
            const double d = cv::norm(rgb - (a + t * ab), cv::NORM_L2SQR);
            if (d < best) best = d, chosen = t < 0.5 ? i : j, cls = palette[chosen].cls;
          }
      }
      out(r, c) = cls;
      if (top_rgb && cls == kPaintTop) (*top_rgb)(r, c) = palette[chosen].linear;
    }
  if (cv::countNonZero(out == kPaintTop) == 0)
    throw Error(origin + ": no pixel is nearest to a top colour; paint the island's top in one of the top_colours");
  size_t border = 0, border_top = 0;
  for (int r = 0; r < out.rows; ++r)
    for (int c = 0; c < out.cols; ++c)
      if (r == 0 || c == 0 || r == out.rows - 1 || c == out.cols - 1) ++border, border_top += out(r, c) == kPaintTop;
  if (2 * border_top > border)
    throw Error(origin + ": the top colour covers most of the image border (a white canvas read as snow?); paint on a "
                         "transparent or sky-blue background, or set background_colours / top_colours");
  return out;
}

cv::Mat1f floating_features(cv::Size size, const FloatingParams& p, uint64_t seed) {
  validate(p);
  const GradientNoise2 noise(derive_seed(seed, 0, "floating-features"));
  Rng rng(derive_seed(seed, 1, "floating-offset"));
  const float ox = float(rng.uniform(0, 256)), oy = float(rng.uniform(0, 256));
  cv::Mat1f h(size);
  const float k = float(1.0 / p.feature_px);
  for (int r = 0; r < size.height; ++r)
    for (int c = 0; c < size.width; ++c)
      h(r, c) = float(p.feature_m * 0.5 * (1.0 + noise.fbm(float(c) * k + ox, float(r) * k + oy, p.octaves)));
  return h;
}

Basemaps floating_basemaps(const cv::Mat1b& blob, double mpp) {
  Basemaps m{cv::Mat1f(blob.size(), 0.f), cv::Mat1f(blob.size(), 0.f), cv::Mat1f(blob.size(), 0.f)};
  // Per row: the span [u_min, u_max] of the blob's pixel centres; the row's
  // half-width σ reaches the pixels' outer edges (+0.5) so edge pixels keep B > 0.
  std::vector<double> mu(size_t(blob.rows), 0), sigma(size_t(blob.rows), 0);
  int v_min = -1, v_max = -1;
  for (int r = 0; r < blob.rows; ++r) {
    int lo = -1, hi = -1;
    for (int c = 0; c < blob.cols; ++c)
      if (blob(r, c)) {
        if (lo < 0) lo = c;
        hi = c;
      }
    if (lo < 0) continue;
    if (v_min < 0) v_min = r;
    v_max = r;
    mu[size_t(r)] = (lo + hi) / 2.0;
    sigma[size_t(r)] = (hi - lo) / 2.0 + 0.5;
  }
  if (v_min < 0) return m;
  for (int r = v_min; r <= v_max; ++r) {
    const double s = sigma[size_t(r)];
    if (s <= 0) continue;  // a row with no blob pixel inside the blob's rows (concave in v)
    const double t = v_max > v_min ? double(r - v_min) / (v_max - v_min) : 0.0;
    // Distance from the row's right end to the straight axis joining the
    // first and last rows' centres: tilts the rock's tip under bulges.
    const double cb_m = std::max(0.0, (mu[size_t(r)] + s - ((1 - t) * mu[size_t(v_min)] + t * mu[size_t(v_max)])) * mpp);
    for (int c = 0; c < blob.cols; ++c) {
      const double x = std::abs(c - mu[size_t(r)]) / s;
      if (x >= 1) continue;
      const double b = std::sin(std::acos(x));
      m.b(r, c) = float(b);
      m.top_m(r, c) = float(s * mpp * b);
      m.bottom_m(r, c) = float(cb_m * b);
    }
  }
  return m;
}

namespace {

// One blob → one closed shell appended to `out`. The silhouette is the zero
// level of f = signed distance to the polygon + 0.5 px (the contour runs
// through the boundary pixels' centres; the painted edge is half a pixel
// further out), cut by marching squares on the pixel-centre grid: inside
// corners and edge crossings make convex cell polygons (fanned), the
// crossing-to-crossing segments are the rim, where a vertical strip joins the
// top to the bottom.
struct ShellStats {
  double top_max_m, depth_m;
};

// Long on purpose (~150 lines): the shell's top, bottom, walls and colours
// share the grid of vertex heights and crossings built at its start; split,
// every piece would carry that grid. Its stages are marked inside.
ShellStats add_shell(const std::vector<cv::Point>& poly, const cv::Rect& bbox, const cv::Mat1f& h0_m,
                     double painted_depth_m, const FloatingParams& p, const cv::Mat3f& top_rgb, const cv::Vec3f& rock,
                     cv::Size canvas, Mesh& out, cv::Mat1f& top_canvas, cv::Mat1f& bottom_canvas) {
  const int x0 = bbox.x - 2, y0 = bbox.y - 2, w = bbox.width + 4, h = bbox.height + 4;
  const double mpp = p.metres_per_px;
  std::vector<cv::Point> local(poly);
  for (auto& q : local) q -= cv::Point(x0, y0);
  cv::Mat1b blob(h, w, uchar(0));
  cv::fillPoly(blob, std::vector<std::vector<cv::Point>>{local}, cv::Scalar(255));
  Basemaps bm = floating_basemaps(blob, mpp);
  if (p.smooth_px > 0) {
    // Normalised convolution inside the blob (the zeros outside do not leak
    // in), then a quarter-circle taper over the last 3σ before the rim, so the
    // basemaps still end at 0 on the silhouette as the formula's do.
    cv::Mat1f weight, den, dist;
    blob.convertTo(weight, CV_32F, 1.0 / 255);
    cv::GaussianBlur(weight, den, cv::Size(0, 0), p.smooth_px, p.smooth_px, cv::BORDER_CONSTANT);
    cv::distanceTransform(blob, dist, cv::DIST_L2, 3);
    const double rho = 3 * p.smooth_px;
    for (cv::Mat1f* m : {&bm.top_m, &bm.bottom_m}) {
      cv::Mat1f num;
      cv::GaussianBlur(m->mul(weight), num, cv::Size(0, 0), p.smooth_px, p.smooth_px, cv::BORDER_CONSTANT);
      for (int i = 0; i < h; ++i)
        for (int j = 0; j < w; ++j) {
          if (!blob(i, j) || den(i, j) <= 1e-6f) {
            (*m)(i, j) = 0.f;
            continue;
          }
          const double u = 1 - std::min(1.0, (dist(i, j) - 0.5) / rho);  // 1 at the rim, 0 from ρ inwards
          (*m)(i, j) = float(num(i, j) / den(i, j) * std::sqrt(std::max(0.0, 1 - u * u)));
        }
    }
  }

  // Signed distance, exact only near the polygon: elsewhere only the sign
  // matters (crossings need both ends of an edge, one of them within 1 px).
  cv::Mat1f f(h, w);
  {
    cv::Mat1f d_in, d_out;
    cv::distanceTransform(blob, d_in, cv::DIST_L2, 3);
    cv::distanceTransform(255 - blob, d_out, cv::DIST_L2, 3);
    std::vector<cv::Point2f> polyf(local.begin(), local.end());
    for (int i = 0; i < h; ++i)
      for (int j = 0; j < w; ++j) {
        const float approx = blob(i, j) ? d_in(i, j) : -d_out(i, j);
        float v = std::abs(approx) < 3.f ? float(cv::pointPolygonTest(polyf, cv::Point2f(float(j), float(i)), true))
                                         : approx;
        v += 0.5f;
        // Keep crossings away from grid vertices: a crossing on a vertex
        // would make zero-area triangles.
        if (std::abs(v) < 0.05f) v = v < 0 ? -0.05f : 0.05f;
        f(i, j) = v;
      }
  }

  // Heights at every grid vertex (outside the blob too: crossings interpolate).
  cv::Mat1f zt(h, w), zb(h, w);
  double raw_min = 0;
  for (int i = 0; i < h; ++i)
    for (int j = 0; j < w; ++j) {
      const int r = std::clamp(y0 + i, 0, h0_m.rows - 1), c = std::clamp(x0 + j, 0, h0_m.cols - 1);
      const double h0 = h0_m(r, c);
      zt(i, j) = float(p.alpha_top * (p.beta_top * bm.top_m(i, j) + (1 - p.beta_top) * h0));
      zb(i, j) = float(p.depth_stretch * p.alpha_bottom * (p.beta_bottom * bm.bottom_m(i, j) + (1 - p.beta_bottom) * h0));
      if (f(i, j) > 0) raw_min = std::min(raw_min, double(zb(i, j)));
    }
  // A painted rock depth rescales the bottom so its tip is that deep.
  const double k = painted_depth_m > 0 && raw_min < 0 ? painted_depth_m / -raw_min : 1.0;
  ShellStats st{-1e30, 0};
  for (int i = 0; i < h; ++i)
    for (int j = 0; j < w; ++j) {
      zb(i, j) = std::min(float(zb(i, j) * k), float(zt(i, j) - p.rim_m));  // never thinner than the rim
      if (f(i, j) > 0) {
        st.top_max_m = std::max(st.top_max_m, double(zt(i, j)));
        st.depth_m = std::max(st.depth_m, -double(zb(i, j)));
        const int r = y0 + i, c = x0 + j;
        if (r >= 0 && c >= 0 && r < canvas.height && c < canvas.width) {
          top_canvas(r, c) = zt(i, j);
          bottom_canvas(r, c) = zb(i, j);
        }
      }
    }

  auto X = [&](double j) { return float((x0 + j - (canvas.width - 1) / 2.0) * mpp); };
  auto Z = [&](double i) { return float((y0 + i - (canvas.height - 1) / 2.0) * mpp); };
  struct Pair {
    uint32_t top, bot;
  };
  const uint32_t none = std::numeric_limits<uint32_t>::max();
  std::vector<Pair> corner(size_t(w) * size_t(h), {none, none});
  std::vector<Pair> hcross(size_t(w) * size_t(h), {none, none}), vcross(size_t(w) * size_t(h), {none, none});
  // Vertex colours: the painted top colour under each top vertex, rock below;
  // the strip blends from one to the other over the rim.
  auto top_colour = [&](int i, int j) {
    return top_rgb(std::clamp(y0 + i, 0, top_rgb.rows - 1), std::clamp(x0 + j, 0, top_rgb.cols - 1));
  };
  auto add = [&](float x, float y, float z, const cv::Vec3f& colour) {
    out.positions.emplace_back(x, y, z);
    out.colors.push_back(colour);
    return uint32_t(out.positions.size() - 1);
  };
  auto corner_of = [&](int i, int j) {
    Pair& q = corner[size_t(i) * size_t(w) + size_t(j)];
    if (q.top == none) q = {add(X(j), zt(i, j), Z(i), top_colour(i, j)), add(X(j), zb(i, j), Z(i), rock)};
    return q;
  };
  // Crossing on the edge from grid vertex a to b (4-neighbours), shared by the two cells.
  auto cross_of = [&](int ia, int ja, int ib, int jb) {
    const bool horizontal = ia == ib;
    const int i = std::min(ia, ib), j = std::min(ja, jb);
    Pair& q = (horizontal ? hcross : vcross)[size_t(i) * size_t(w) + size_t(j)];
    if (q.top == none) {
      const float fa = f(ia, ja), fb = f(ib, jb), t = fa / (fa - fb);
      auto lerp = [&](float a, float b) { return a + t * (b - a); };
      const float x = lerp(X(ja), X(jb)), z = lerp(Z(ia), Z(ib));
      const cv::Vec3f colour = fa > 0 ? top_colour(ia, ja) : top_colour(ib, jb);  // the inside end's
      q = {add(x, lerp(zt(ia, ja), zt(ib, jb)), z, colour), add(x, lerp(zb(ia, ja), zb(ib, jb)), z, rock)};
    }
    return q;
  };
  struct PolyVertex {
    Pair v;
    bool crossing;
  };
  std::vector<PolyVertex> cell;
  for (int i = 0; i + 1 < h; ++i)
    for (int j = 0; j + 1 < w; ++j) {
      // Corners top-left, bottom-left, bottom-right, top-right: counter-clockwise seen from above.
      const int ci[4] = {i, i + 1, i + 1, i}, cj[4] = {j, j, j + 1, j + 1};
      cell.clear();
      for (int k = 0; k < 4; ++k) {
        const int n = (k + 1) % 4;
        const bool in_k = f(ci[k], cj[k]) > 0, in_n = f(ci[n], cj[n]) > 0;
        if (in_k) cell.push_back({corner_of(ci[k], cj[k]), false});
        if (in_k != in_n) cell.push_back({cross_of(ci[k], cj[k], ci[n], cj[n]), true});
      }
      const size_t n = cell.size();
      if (n < 3) continue;
      for (size_t k = 1; k + 1 < n; ++k) {  // cell polygons are convex: a fan
        out.triangles.push_back({cell[0].v.top, cell[k].v.top, cell[k + 1].v.top});
        out.triangles.push_back({cell[0].v.bot, cell[k + 1].v.bot, cell[k].v.bot});  // bottom faces down
      }
      for (size_t k = 0; k < n; ++k) {  // crossing → crossing is the rim: the strip's quad, facing out
        const PolyVertex &a = cell[k], &b = cell[(k + 1) % n];
        if (!a.crossing || !b.crossing) continue;
        out.triangles.push_back({a.v.top, a.v.bot, b.v.bot});
        out.triangles.push_back({a.v.top, b.v.bot, b.v.top});
      }
    }
  return st;
}

}  // namespace

FloatingIsland floating_island(const cv::Mat1b& labels, const cv::Mat1f& h0_m, const FloatingParams& p,
                               const cv::Mat3f& top_rgb_in) {
  validate(p);
  if (labels.empty() || labels.size() != h0_m.size())
    throw Error("floating: the feature field must have the painting's size");
  if (!top_rgb_in.empty() && top_rgb_in.size() != labels.size())
    throw Error("floating: the top colours must have the painting's size");
  // Top colour per pixel, grown a few pixels past the painted top (the mesh
  // reaches half a pixel beyond it, and the polygon may cut corners).
  const cv::Vec3f first_top = linear_rgb(p.top_colours.front());
  const cv::Vec3f rock = p.bottom_colours.empty() ? linear_rgb("#8b5a2b") : linear_rgb(p.bottom_colours.front());
  cv::Mat3f top_rgb(labels.size(), first_top);
  if (!top_rgb_in.empty()) {
    cv::Mat1b known = labels == kPaintTop;
    top_rgb_in.copyTo(top_rgb, known);
    for (int pass = 0; pass < 3; ++pass) {
      const cv::Mat1b before = known.clone();
      for (int r = 0; r < labels.rows; ++r)
        for (int c = 0; c < labels.cols; ++c) {
          if (before(r, c)) continue;
          for (const cv::Point d : {cv::Point(-1, 0), cv::Point(1, 0), cv::Point(0, -1), cv::Point(0, 1)}) {
            const int rr = r + d.y, cc = c + d.x;
            if (rr < 0 || cc < 0 || rr >= labels.rows || cc >= labels.cols || !before(rr, cc)) continue;
            top_rgb(r, c) = top_rgb(rr, cc);
            known(r, c) = 255;
            break;
          }
        }
    }
  }
  FloatingIsland isl;
  isl.top_m = cv::Mat1f(labels.size(), std::numeric_limits<float>::quiet_NaN());
  isl.bottom_m = isl.top_m.clone();
  const cv::Mat1b top = labels == kPaintTop;
  // Top blobs (8-connected, as contours are traced) and the painted rock that
  // hangs from each: the bottom pixels in the same top∪bottom component.
  cv::Mat1i blob_id, stats, union_id;
  cv::Mat1d centroids;
  const int blobs = cv::connectedComponentsWithStats(top, blob_id, stats, centroids, 8, CV_32S);
  const cv::Mat1b painted = (labels == kPaintTop) | (labels == kPaintBottom);
  const int unions = cv::connectedComponents(painted, union_id, 8, CV_32S);
  std::vector<int> rock_bottom_row(size_t(unions), -1);
  for (int r = 0; r < labels.rows; ++r)
    for (int c = 0; c < labels.cols; ++c)
      if (labels(r, c) == kPaintBottom) rock_bottom_row[size_t(union_id(r, c))] = r;  // rows ascend: the last is lowest
  double top_max = -1e30;
  for (int b = 1; b < blobs; ++b) {
    if (stats(b, cv::CC_STAT_AREA) < p.min_area_px) continue;
    const cv::Mat1b one = blob_id == b;
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(one, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    if (contours.empty()) continue;
    const auto& contour = *std::max_element(contours.begin(), contours.end(),
                                            [](const auto& a, const auto& c) { return a.size() < c.size(); });
    std::vector<cv::Point> poly;
    if (p.simplify_px > 0) cv::approxPolyDP(contour, poly, p.simplify_px, true);
    if (poly.size() < 3) poly = contour;
    const cv::Rect bbox = cv::boundingRect(contour) | cv::boundingRect(poly);
    const int lowest_top_row = bbox.y + bbox.height - 1;
    const int rock_row = rock_bottom_row[size_t(union_id(contour[0].y, contour[0].x))];
    const double painted_depth_m = rock_row > lowest_top_row ? (rock_row - lowest_top_row) * p.metres_per_px : 0.0;
    const ShellStats st =
        add_shell(poly, bbox, h0_m, painted_depth_m, p, top_rgb, rock, labels.size(), isl.mesh, isl.top_m, isl.bottom_m);
    top_max = std::max(top_max, st.top_max_m);
    isl.depth_m = std::max(isl.depth_m, st.depth_m);
    ++isl.islands;
  }
  if (isl.islands == 0)
    throw Error("floating: no top blob has " + std::to_string(p.min_area_px) +
                " pixels or more; paint a bigger top or lower min_area_px");
  isl.top_max_m = top_max;
  // The painting drapes onto the top: texture coordinates over the canvas.
  isl.mesh.uvs = planar_uvs(isl.mesh, labels.cols * p.metres_per_px, labels.rows * p.metres_per_px);
  return isl;
}

cv::Mat1b mesh_silhouette(const Mesh& m, cv::Size canvas, double mpp) {
  // Our own point-in-triangle at pixel centres (OpenCV's polygon fill rounds
  // edges by up to a pixel, which is the size of what this measures).
  cv::Mat1b out(canvas, uchar(0));
  auto px = [&](const cv::Vec3f& v) {
    return cv::Point2d(v[0] / mpp + (canvas.width - 1) / 2.0, v[2] / mpp + (canvas.height - 1) / 2.0);
  };
  for (const auto& t : m.triangles) {
    const cv::Point2d a = px(m.positions[t[0]]), b = px(m.positions[t[1]]), c = px(m.positions[t[2]]);
    const double area2 = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (std::abs(area2) < 1e-9) continue;  // seen edge-on (the rim's strip)
    const int x_lo = std::max(0, int(std::ceil(std::min({a.x, b.x, c.x}))));
    const int x_hi = std::min(canvas.width - 1, int(std::floor(std::max({a.x, b.x, c.x}))));
    const int y_lo = std::max(0, int(std::ceil(std::min({a.y, b.y, c.y}))));
    const int y_hi = std::min(canvas.height - 1, int(std::floor(std::max({a.y, b.y, c.y}))));
    auto edge = [](const cv::Point2d& p, const cv::Point2d& q, double x, double y) {
      return (q.x - p.x) * (y - p.y) - (q.y - p.y) * (x - p.x);
    };
    const double sgn = area2 > 0 ? 1 : -1, eps = 1e-9 * std::abs(area2);
    for (int y = y_lo; y <= y_hi; ++y)
      for (int x = x_lo; x <= x_hi; ++x)
        if (sgn * edge(a, b, x, y) >= -eps && sgn * edge(b, c, x, y) >= -eps && sgn * edge(c, a, x, y) >= -eps)
          out(y, x) = 255;
  }
  return out;
}

double mask_iou(const cv::Mat1b& a, const cv::Mat1b& b) {
  if (a.size() != b.size()) throw Error("mask_iou: masks differ in size");
  const double inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni > 0 ? inter / uni : 1.0;
}

cv::Mat3b render_mesh(const Mesh& m, int width_px, double yaw_deg, double pitch_deg) {
  const int W = std::max(64, width_px), H = W * 3 / 4;
  cv::Mat3b img(H, W);
  for (int r = 0; r < H; ++r)  // sky gradient
    img.row(r).setTo(cv::Vec3b(uchar(235 - 40 * r / H), uchar(215 - 30 * r / H), uchar(180 - 40 * r / H)));
  if (m.triangles.empty()) return img;
  const double yaw = yaw_deg * CV_PI / 180, pitch = pitch_deg * CV_PI / 180;
  // Camera: rotate about +Y by yaw, then tilt about +X by pitch; orthographic.
  std::vector<cv::Vec3d> q(m.positions.size());
  cv::Vec2d lo(1e30, 1e30), hi(-1e30, -1e30);
  for (size_t i = 0; i < q.size(); ++i) {
    const cv::Vec3d v(m.positions[i]);
    const double x1 = std::cos(yaw) * v[0] - std::sin(yaw) * v[2], z1 = std::sin(yaw) * v[0] + std::cos(yaw) * v[2];
    const double y2 = std::cos(pitch) * v[1] - std::sin(pitch) * z1, z2 = std::sin(pitch) * v[1] + std::cos(pitch) * z1;
    q[i] = {x1, -y2, z2};  // screen x right, screen y down, depth towards the viewer
    lo = {std::min(lo[0], x1), std::min(lo[1], -y2)};
    hi = {std::max(hi[0], x1), std::max(hi[1], -y2)};
  }
  const double s = 0.9 * std::min(W / std::max(1e-9, hi[0] - lo[0]), H / std::max(1e-9, hi[1] - lo[1]));
  const cv::Vec2d off((W - s * (hi[0] - lo[0])) / 2 - s * lo[0], (H - s * (hi[1] - lo[1])) / 2 - s * lo[1]);
  for (auto& v : q) v = {v[0] * s + off[0], v[1] * s + off[1], v[2]};
  cv::Mat1d depth(H, W, -1e300);
  const cv::Vec3d light = cv::normalize(cv::Vec3d(-0.4, 0.8, 0.45));
  for (const auto& t : m.triangles) {
    const cv::Vec3d a(m.positions[t[0]]), b(m.positions[t[1]]), c(m.positions[t[2]]);
    cv::Vec3d n = (b - a).cross(c - a);
    const double len = cv::norm(n);
    if (len <= 0) continue;
    n /= len;
    const double shade = 0.35 + 0.65 * std::max(0.0, n.dot(light));
    // Grass on faces looking up, rock elsewhere (BGR).
    const cv::Vec3d base = n[1] > 0.5 ? cv::Vec3d(60, 150, 80) : cv::Vec3d(50, 85, 125);
    const cv::Vec3d& A = q[t[0]];
    const cv::Vec3d& B = q[t[1]];
    const cv::Vec3d& C = q[t[2]];
    const double den = (B[1] - C[1]) * (A[0] - C[0]) + (C[0] - B[0]) * (A[1] - C[1]);
    if (std::abs(den) < 1e-12) continue;
    const int x_lo = std::max(0, int(std::floor(std::min({A[0], B[0], C[0]}))));
    const int x_hi = std::min(W - 1, int(std::ceil(std::max({A[0], B[0], C[0]}))));
    const int y_lo = std::max(0, int(std::floor(std::min({A[1], B[1], C[1]}))));
    const int y_hi = std::min(H - 1, int(std::ceil(std::max({A[1], B[1], C[1]}))));
    for (int y = y_lo; y <= y_hi; ++y)
      for (int x = x_lo; x <= x_hi; ++x) {
        const double l0 = ((B[1] - C[1]) * (x - C[0]) + (C[0] - B[0]) * (y - C[1])) / den;
        const double l1 = ((C[1] - A[1]) * (x - C[0]) + (A[0] - C[0]) * (y - C[1])) / den;
        const double l2 = 1 - l0 - l1;
        if (l0 < 0 || l1 < 0 || l2 < 0) continue;
        const double d = l0 * A[2] + l1 * B[2] + l2 * C[2];
        if (d <= depth(y, x)) continue;
        depth(y, x) = d;
        img(y, x) = cv::Vec3b(cv::saturate_cast<uchar>(base[0] * shade), cv::saturate_cast<uchar>(base[1] * shade),
                              cv::saturate_cast<uchar>(base[2] * shade));
      }
  }
  return img;
}

cv::Mat shrink_painting(const cv::Mat& image, int max_px, FloatingParams& p) {
  if (max_px < 0) throw Error("--max-size must be ≥ 0");
  const int long_side = std::max(image.cols, image.rows);
  if (max_px == 0 || long_side <= max_px) return image;
  const double k = double(max_px) / long_side;
  cv::Mat small;
  cv::resize(image, small,
             cv::Size(std::max(1, int(std::lround(image.cols * k))), std::max(1, int(std::lround(image.rows * k)))), 0,
             0, cv::INTER_AREA);
  p.metres_per_px *= double(image.cols) / small.cols;
  p.feature_px = std::max(1.0, p.feature_px * small.cols / double(image.cols));
  p.smooth_px *= double(small.cols) / image.cols;
  return small;
}

void check_floating_heights(const cv::Mat1f& height_m, const std::string& origin) {
  for (const float v : height_m) {
    if (!std::isfinite(v)) throw Error(origin + ": height field holds NaN or infinity; regenerate it");
    // Beyond ±100 km a float32 mesh loses its sub-metre steps and is no longer closed.
    if (std::abs(v) > 1e5f)
      throw Error(origin + ": height " + std::to_string(v) + " m is beyond ±100 km; is it in metres?");
  }
}

HeightTop top_of_height_field(const cv::Mat1f& height_m, const std::string& origin) {
  check_floating_heights(height_m, origin);
  HeightTop t;
  t.labels = cv::Mat1b(height_m.size());
  for (int r = 0; r < height_m.rows; ++r)
    for (int c = 0; c < height_m.cols; ++c) t.labels(r, c) = height_m(r, c) > 0 ? kPaintTop : kPaintBackground;
  if (cv::countNonZero(t.labels) == 0)
    throw Error(origin + ": no land (no height above 0 m) to float; use a terrain with land, or paint the outline (--painting)");
  t.h0_m = cv::max(height_m, 0.f);
  return t;
}

}  // namespace reefgen::islands
