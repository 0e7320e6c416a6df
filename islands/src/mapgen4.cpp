#include <algorithm>
#include <map>
#include <cmath>
#include "reefgen/files.hpp"
#include <vector>

#include <opencv2/imgproc.hpp>

#include "reefgen/terrain/noise.hpp"
#include "reefgen/islands/terrains.hpp"
#include "reefgen/rng.hpp"

namespace reefgen::islands {

using terrain::GradientNoise2;
using terrain::NoiseTile;

std::vector<cv::Point2d> poisson_disk(double radius, uint64_t seed) {
  Rng rng(derive_seed(seed, 0, "poisson"));
  const double cell = radius / std::sqrt(2.0);
  const int n = int(std::ceil(2.0 / cell));
  std::vector<int> grid(size_t(n) * size_t(n), -1);  // one point per cell at most
  std::vector<cv::Point2d> pts;
  std::vector<size_t> active;
  auto cell_of = [&](double v) { return std::clamp(int((v + 1) / cell), 0, n - 1); };
  auto add = [&](cv::Point2d q) {
    grid[size_t(cell_of(q.y)) * size_t(n) + size_t(cell_of(q.x))] = int(pts.size());
    active.push_back(pts.size());
    pts.push_back(q);
  };
  add({rng.uniform(-1, 1), rng.uniform(-1, 1)});
  while (!active.empty()) {
    const size_t k = size_t(rng.uniform_int(0, int64_t(active.size()) - 1));
    const cv::Point2d c = pts[active[k]];
    bool placed = false;
    for (int t = 0; t < 30 && !placed; ++t) {
      const double a = rng.uniform(0, 2 * M_PI), r = radius * (1 + rng.uniform());
      const cv::Point2d q(c.x + r * std::cos(a), c.y + r * std::sin(a));
      if (q.x < -1 || q.x > 1 || q.y < -1 || q.y > 1) continue;
      const int gx = cell_of(q.x), gy = cell_of(q.y);
      bool ok = true;
      for (int y = std::max(0, gy - 2); y <= std::min(n - 1, gy + 2) && ok; ++y)
        for (int x = std::max(0, gx - 2); x <= std::min(n - 1, gx + 2) && ok; ++x) {
          const int j = grid[size_t(y) * size_t(n) + size_t(x)];
          if (j >= 0 && std::hypot(pts[size_t(j)].x - q.x, pts[size_t(j)].y - q.y) < radius) ok = false;
        }
      if (ok) add(q), placed = true;
    }
    if (!placed) {
      active[k] = active.back();
      active.pop_back();
    }
  }
  return pts;
}

// Long: mapgen4's recipe in its order (points, elevation, Delaunay, the dual
// mesh drawn to pixels), each step marked; they share the point and
// triangle arrays, which is how the original reads too.
cv::Mat1f mapgen4_height(const Mapgen4Params& p, uint64_t seed) {
  check_params(p, "mapgen4", "configs/terrains/mapgen4.json");
  if (!(p.mountain_spacing >= p.spacing))
    throw Error("mapgen4: mountain_spacing = " + std::to_string(p.mountain_spacing) + " is below spacing = " +
                std::to_string(p.spacing));
  const bool round_falloff = p.falloff == "euclidean";

  std::vector<cv::Point2d> pts = poisson_disk(p.spacing, seed);
  // Boundary rings (on the edge and one spacing outside) so that the
  // triangulation covers the whole canvas with well-shaped triangles.
  const int ring = int(std::ceil(2.0 / p.spacing));
  for (double off : {1.0, 1.0 + p.spacing})
    for (int i = 0; i < ring; ++i) {
      const double t = -off + 2 * off * i / ring;
      for (cv::Point2d q : {cv::Point2d(t, -off), cv::Point2d(off, t), cv::Point2d(-t, off), cv::Point2d(-off, -t)})
        pts.push_back(q);
    }
  const std::vector<cv::Point2d> peaks = poisson_disk(p.mountain_spacing, derive_seed(seed, 1, "peaks"));

  const GradientNoise2 fbm(derive_seed(seed, 2, "mapgen4-fbm")), n1(derive_seed(seed, 3, "ridge1")),
      n2(derive_seed(seed, 4, "ridge2"));
  auto elevation = [&](double x, double y) {
    // Chebyshev distance (the recipe's) gives squarish coasts; Euclidean, round ones.
    const double d = round_falloff ? std::hypot(x, y) : std::max(std::abs(x), std::abs(y));
    double e = (p.k_fbm * fbm.fbm(float(x * p.frequency), float(y * p.frequency), 5) + p.k_d * (0.75 - 2 * d * d)) / 2;
    // Ridges near the peak seeds: R = n1 + n2 (lower frequency twice), r = max(0, 1-|R|).
    double near = 0;
    for (const auto& k : peaks) near = std::max(near, 1 - std::hypot(x - k.x, y - k.y) / p.mountain_spacing);
    const double R = n1.fbm(float(x * p.frequency * 1.5), float(y * p.frequency * 1.5), 3) +
                     n2.fbm(float(x * p.frequency * 1.5 + 31.7), float(y * p.frequency * 1.5 - 12.3), 3);
    const double r = std::max(0.0, 1 - std::abs(R)) * std::max(0.0, near);
    const double s = std::clamp(5 * e, 0.0, 1.0);
    return std::max(e, std::min(3 * e, s * r));
  };

  // Delaunay in pixel coordinates (Subdiv2D wants a bounding rectangle).
  const int W = p.size_px;
  auto to_px = [&](const cv::Point2d& q) { return cv::Point2f(float((q.x + 1) / 2 * W), float((1 - q.y) / 2 * W)); };
  const float margin = float(W);
  cv::Subdiv2D dt(cv::Rect(int(-margin), int(-margin), int(W + 2 * margin), int(W + 2 * margin)));
  for (const auto& q : pts) dt.insert(to_px(q));
  std::vector<cv::Vec6f> tris;
  dt.getTriangleList(tris);

  // mapgen4's dual mesh: each Delaunay triangle t has its Voronoi vertex at
  // its centroid g_t (not the circumcentre: centroids keep cells well shaped
  // near the boundary), elevation e_t = e(g_t); each point r (a Voronoi
  // cell) takes the mean of its triangles' elevations. Drawn as mapgen4
  // draws it: for every Delaunay edge (a, b) between triangles t and t′, the
  // two triangles (a, g_t, g_t′) and (b, g_t′, g_t), so the facets follow the
  // cells' edges (g_t–g_t′), which is where mapgen4's look comes from.
  std::map<std::pair<float, float>, int> index_of;
  std::vector<cv::Point2f> site;
  for (const auto& q : pts) {
    const cv::Point2f v = to_px(q);
    if (index_of.emplace(std::make_pair(v.x, v.y), int(site.size())).second) site.push_back(v);
  }
  struct Tri {
    int v[3];
    cv::Point2f g;
    double e;
  };
  std::vector<Tri> tri;
  for (const auto& t : tris) {
    Tri x{};
    bool ok = true;  // skips triangles touching Subdiv2D's virtual outer vertices
    for (int k = 0; k < 3; ++k) {
      const auto it = index_of.find({t[2 * k], t[2 * k + 1]});
      if (it == index_of.end()) ok = false;
      else x.v[k] = it->second;
    }
    if (!ok) continue;
    x.g = (site[size_t(x.v[0])] + site[size_t(x.v[1])] + site[size_t(x.v[2])]) / 3.f;
    x.e = elevation(x.g.x / W * 2.0 - 1, 1 - x.g.y / W * 2.0);
    tri.push_back(x);
  }
  std::vector<double> e_sum(site.size(), 0.0);
  std::vector<int> e_n(site.size(), 0);
  std::map<std::pair<int, int>, std::vector<int>> edge_tris;  // Delaunay edge → its one or two triangles
  for (int i = 0; i < int(tri.size()); ++i)
    for (int k = 0; k < 3; ++k) {
      const int a = tri[size_t(i)].v[k], b = tri[size_t(i)].v[(k + 1) % 3];
      e_sum[size_t(a)] += tri[size_t(i)].e;
      ++e_n[size_t(a)];
      edge_tris[{std::min(a, b), std::max(a, b)}].push_back(i);
    }
  auto e_site = [&](int r) { return e_n[size_t(r)] ? e_sum[size_t(r)] / e_n[size_t(r)] : 0.0; };

  cv::Mat1f e_px(W, W, std::numeric_limits<float>::quiet_NaN());
  auto fill = [&](cv::Point2f a, double ea, cv::Point2f b, double eb, cv::Point2f c, double ec) {
    const double den = double(b.y - c.y) * (a.x - c.x) + double(c.x - b.x) * (a.y - c.y);
    if (std::abs(den) < 1e-12) return;
    const int x0 = std::max(0, int(std::floor(std::min({a.x, b.x, c.x})))), x1 = std::min(W - 1, int(std::ceil(std::max({a.x, b.x, c.x}))));
    const int y0 = std::max(0, int(std::floor(std::min({a.y, b.y, c.y})))), y1 = std::min(W - 1, int(std::ceil(std::max({a.y, b.y, c.y}))));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        const double l1 = ((b.y - c.y) * (px - c.x) + (c.x - b.x) * (py - c.y)) / den;
        const double l2 = ((c.y - a.y) * (px - c.x) + (a.x - c.x) * (py - c.y)) / den;
        const double l3 = 1 - l1 - l2;
        if (l1 < -1e-9 || l2 < -1e-9 || l3 < -1e-9) continue;
        e_px(y, x) = float(l1 * ea + l2 * eb + l3 * ec);
      }
  };
  for (const auto& [edge, ts] : edge_tris) {
    const auto [a, b] = edge;
    const cv::Point2f pa = site[size_t(a)], pb = site[size_t(b)];
    const Tri& t = tri[size_t(ts[0])];
    if (ts.size() == 2) {
      const Tri& u = tri[size_t(ts[1])];
      fill(pa, e_site(a), t.g, t.e, u.g, u.e);
      fill(pb, e_site(b), u.g, u.e, t.g, t.e);
    } else {  // hull edge (outside the canvas: the rings): close the fan at the edge
      fill(pa, e_site(a), pb, e_site(b), t.g, t.e);
    }
  }
  cv::Mat1f h(W, W);
  for (int y = 0; y < W; ++y)
    for (int x = 0; x < W; ++x) {
      float e = e_px(y, x);
      if (std::isnan(e)) e = float(elevation((x + 0.5) / W * 2 - 1, 1 - (y + 0.5) / W * 2));  // never expected; safe
      h(y, x) = e >= 0 ? float(p.peak_m * std::min(1.0f, e)) : float(std::max(-p.depth_m, p.depth_m * e / 0.5));
    }
  return h;
}

}  // namespace reefgen::islands
