#include "reefgen/terrain/layers.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/parallel.hpp"
#include "reefgen/ramp.hpp"
#include "reefgen/terrain/drainage.hpp"
#include "reefgen/terrain/flow.hpp"
#include "layers_parts.hpp"

namespace reefgen::terrain {

namespace detail {

constexpr double kRadToDeg = 180.0 / M_PI;

// row(y) for every y < rows, in bands of rows shared out over `threads`
// (each pixel written by one thread only: same bytes whatever the count).
void for_rows(int rows, int threads, const std::function<void(int)>& row) {
  constexpr int kBand = 32;
  const size_t bands = size_t((rows + kBand - 1) / kBand);
  parallel_for(bands, std::max(1, threads), [&](size_t b) {
    for (int y = int(b) * kBand; y < std::min(rows, int(b + 1) * kBand); ++y) row(y);
  });
}

// A Gaussian-like blur whose cost does not grow with σ: three box passes of
// width w have variance 3(w² − 1)/12 = σ² (a wide Gaussian at 4097² would
// take seconds per map).
cv::Mat1f soft_blur(const cv::Mat1f& m, double sigma_px) {
  cv::Mat1f out = m.clone();
  if (sigma_px < 0.5) return out;
  if (sigma_px < 3) {
    cv::GaussianBlur(m, out, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
    return out;
  }
  const int w = 2 * int(std::lround(std::sqrt(4 * sigma_px * sigma_px + 1) / 2)) + 1;  // odd
  for (int pass = 0; pass < 3; ++pass) cv::blur(out, out, cv::Size(w, w), cv::Point(-1, -1), cv::BORDER_REPLICATE);
  return out;
}

cv::Mat1f region_share(const cv::Mat1b& region, int id, double sigma_px) {
  cv::Mat1f one(region.size());
  for (int y = 0; y < region.rows; ++y)
    for (int x = 0; x < region.cols; ++x) one(y, x) = region(y, x) == id ? 1.f : 0.f;
  return soft_blur(one, sigma_px);
}

// Slope (degrees) and unit normals by central differences (one-sided on the
// canvas edge). Row 0 is north, so the north component reads upwards.
void slope_and_normals(const cv::Mat1f& h, double dx, cv::Mat1f& slope_deg, cv::Mat3f& normal, int threads) {
  const int H = h.rows, W = h.cols;
  slope_deg.create(H, W);
  normal.create(H, W);
  for_rows(H, threads, [&](int y) {
    const int yn = std::max(y - 1, 0), ys = std::min(y + 1, H - 1);
    for (int x = 0; x < W; ++x) {
      const int xw = std::max(x - 1, 0), xe = std::min(x + 1, W - 1);
      const double gx = (h(y, xe) - h(y, xw)) / ((xe - xw) * dx);
      const double gy = (h(yn, x) - h(ys, x)) / ((ys - yn) * dx);  // towards north
      const double g = std::sqrt(gx * gx + gy * gy), len = std::sqrt(1 + g * g);
      slope_deg(y, x) = float(std::atan(g) * kRadToDeg);
      normal(y, x) = cv::Vec3f(float(-gx / len), float(-gy / len), float(1 / len));
    }
  });
}

// Drainage area on the land's box (islands are a minority of the canvas);
// `graph` indexes that box, `box` says where it is.
cv::Mat1f drainage_area(const cv::Mat1f& h, double dx, FlowGraph& graph, cv::Rect& box) {
  cv::Mat1f out(h.size(), 0.f);
  box = land_box(h);
  if (box.empty()) return out;
  const cv::Mat1f hc = h(box).clone();
  const cv::Mat1b role = sea_and_edge_roles(hc);
  route_flood(hc, role, dx, graph);
  std::vector<float> area;
  accumulate_multiple(graph, role, float(dx * dx), dx, 1.f, area);
  for (const int i : graph.stack) out(box.y + i / box.width, box.x + i % box.width) = area[size_t(i)];
  return out;
}

// Where the material the erosion removed settles (heights are not changed:
// a mask for texturing, in metres). The wear of each cell joins the
// sediment passing through it, which follows the steepest-descent
// receivers. On a slope gentler than settle_deg a share settles in each
// cell, (1 − exp(−Δx / L)) · (1 − S / S_c), which falls to nothing at S_c,
// and never more than builds the cell up to a slope of S_c above its
// receiver (an angle of repose): it lies at slope feet, in valley floors and
// on coastal fans, a few metres thick. What reaches the sea is lost; mass
// is kept (Σ deposit ≤ Σ wear).
void settle_sediment(const FlowGraph& g, const cv::Rect& box, const cv::Mat1f& h_full, const cv::Mat1f& wear_full,
                     const cv::Mat1f& slope_full, double dx, double settle_deg, cv::Mat1f& deposit_full) {
  if (box.empty()) return;
  const cv::Mat1f h = h_full(box), wear_m = wear_full(box), slope_deg = slope_full(box);
  cv::Mat1f deposit_m = deposit_full(box);
  // Settling length on the flat: a flat floor keeps 1 − 1/e of what
  // crosses 300 m of it (a valley fill, not a single-cell heap).
  constexpr double kSettleLengthM = 300;
  const double keep_flat = 1.0 - std::exp(-dx / kSettleLengthM), repose = std::tan(settle_deg / kRadToDeg);
  const int W = wear_m.cols;
  std::vector<double> passing(size_t(wear_m.total()), 0.0);
  const double a = dx * dx;
  for (size_t k = g.stack.size(); k-- > 0;) {
    const int i = g.stack[k], y = i / W, x = i % W, r = g.receiver[size_t(i)];
    const double in = passing[size_t(i)] + double(wear_m(y, x)) * a;
    const double share = keep_flat * std::clamp(1.0 - slope_deg(y, x) / settle_deg, 0.0, 1.0);
    const double room_m = std::max(0.0, double(h(r / W, r % W)) + repose / g.inv_length[size_t(i)] - h(y, x));
    const double laid_m = std::min(share * in / a, room_m);
    deposit_m(y, x) += float(laid_m);
    if (r != i) passing[size_t(r)] += in - laid_m * a;
  }
}

void check_inputs(const cv::Mat1f& h, const cv::Mat1f& before, const cv::Mat1b& region, double dx) {
  if (h.empty()) throw Error("layers: the height field is empty");
  if (!(dx > 0) || !std::isfinite(dx)) throw Error("layers: metres per pixel must be a positive number");
  if (!before.empty() && before.size() != h.size()) throw Error("layers: the uneroded heights differ in size");
  if (!region.empty() && region.size() != h.size()) throw Error("layers: the region map differs in size");
  if (!cv::checkRange(h)) throw Error("layers: the height field holds NaN or infinite values");
}

}  // namespace detail

using namespace detail;

void material_weights(const PixelFacts& f, const LayerParams& p, float w[kNumMaterials]) {
  const double v = f.height_m, slope = f.slope_deg;
  // Water and land share a half-metre band at the coast.
  const float sea = 1.f - ramp(-0.25, 0.25, v), land = 1.f - sea;
  // Under water: deep sea floor where painted abyss or deep, else reef
  // cover on the reef region, lagoon sand elsewhere.
  const float deep = ramp(0.6 * p.deep_sea_m, p.deep_sea_m, -v);
  const float open = std::clamp(f.abyss + (1.f - f.abyss) * deep, 0.f, 1.f);
  w[kDeepSeaFloor] = sea * open;
  w[kReefCover] = sea * (1.f - open) * std::clamp(f.reef, 0.f, 1.f);
  w[kLagoonSand] = sea * (1.f - open) * (1.f - std::clamp(f.reef, 0.f, 1.f));
  // On land, each cover takes its share of what the ones before it left:
  // rock on cliffs, riverbeds, scree (steep or on talus), beach, vegetation.
  const double log_river = std::log10(p.river_area_m2);
  const float cliff = ramp(p.cliff_deg, p.cliff_deg + 6, slope);
  const float river = ramp(log_river, log_river + 1, std::log10(std::max(1e-6f, f.flow_area_m2)));
  const float scree = std::max(ramp(p.scree_deg, p.scree_deg + 4, slope),
                               ramp(0, p.scree_deposit_m, f.deposit_m) * ramp(10, 15, slope));
  // Beach sand on low land; the beach region (painted, or the generator's
  // band, which climbs a young volcano's flank) only where it is low too.
  const float low = 1.f - ramp(0.5 * p.beach_top_m, p.beach_top_m, v);
  const float painted = std::clamp(f.beach, 0.f, 1.f) * (1.f - ramp(p.beach_top_m, 3 * p.beach_top_m, v));
  const float shore = std::max(low, painted);
  float left = land;
  w[kRockCliff] = left * cliff, left -= w[kRockCliff];
  w[kRiverbed] = left * river, left -= w[kRiverbed];
  w[kScree] = left * scree, left -= w[kScree];
  w[kBeachSand] = left * shore, left -= w[kBeachSand];
  w[kVegetation] = std::max(0.f, left);
  float sum = 0.f;
  for (int m = 0; m < kNumMaterials; ++m) sum += w[m];
  for (int m = 0; m < kNumMaterials; ++m) w[m] /= sum;
}

const char* material_name(int m) {
  static constexpr const char* kNames[kNumMaterials] = {"deep_sea_floor", "lagoon_sand", "reef",  "beach_sand",
                                                        "vegetation",     "rock_cliff",  "scree", "riverbed"};
  return (m >= 0 && m < kNumMaterials) ? kNames[m] : "?";
}

void to_json(nlohmann::json& j, const LayerParams& p) { j = params_json(p); }

LayerParams layer_params_from_json(const nlohmann::json& j, const std::string& origin) {
  return params_from_json<LayerParams>(j, origin, "docs/LAYERS.md", "layers.");
}

cv::Mat1b regions_of_heights(const cv::Mat1f& h, const LayerParams& p) {
  // Depths of the generator's bands (docs/SPEC.md): lagoon floors sit within
  // 10 m, the reef's fore-slope reaches about 30 m.
  static constexpr float kLagoonFloorM = -10.f, kReefFootM = -30.f;
  cv::Mat1b r(h.size());
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      const float v = h(y, x);
      r(y, x) = v > p.beach_top_m ? kIsland : v > 0 ? kBeach : v > kLagoonFloorM ? kLagoon : v > kReefFootM ? kReef : kAbyss;
    }
  return r;
}

Layers compute_layers(const cv::Mat1f& h, const cv::Mat1f& before, const cv::Mat1b& region_in, double dx,
                      const LayerParams& p, int threads) {
  check_inputs(h, before, region_in, dx);
  const int H = h.rows, W = h.cols;
  Layers L;
  slope_and_normals(h, dx, L.slope_deg, L.normal, threads);
  FlowGraph graph;
  cv::Rect box;
  L.flow_area_m2 = drainage_area(h, dx, graph, box);
  // Every land cell drains at least itself (the canvas edge's cells are
  // outlets of the routing, with nothing accumulated): 0 is the sea's.
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (h(y, x) > 0) L.flow_area_m2(y, x) = std::max(L.flow_area_m2(y, x), float(dx * dx));
  L.wear_m = cv::Mat1f(H, W, 0.f);
  L.deposit_m = cv::Mat1f(H, W, 0.f);
  if (!before.empty())
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const float d = h(y, x) - before(y, x);
        if (d < 0) L.wear_m(y, x) = -d;
        else if (raised_is_fill(h, y, x, L.slope_deg(y, x), p.settle_deg)) L.deposit_m(y, x) = d;
      }
  settle_sediment(graph, box, h, L.wear_m, L.slope_deg, dx, p.settle_deg, L.deposit_m);
  const cv::Mat1b region = region_in.empty() ? regions_of_heights(h, p) : region_in;
  const double sigma_px = p.region_blend_m / dx;
  const cv::Mat1f abyss = region_share(region, kAbyss, sigma_px), reef = region_share(region, kReef, sigma_px),
                  beach = region_share(region, kBeach, sigma_px);
  for (auto& w : L.weight) w.create(H, W);
  for_rows(H, threads, [&](int y) {
    for (int x = 0; x < W; ++x) {
      float w[kNumMaterials];
      material_weights({h(y, x), L.slope_deg(y, x), L.flow_area_m2(y, x), L.deposit_m(y, x), abyss(y, x), reef(y, x),
                        beach(y, x)},
                       p, w);
      for (int m = 0; m < kNumMaterials; ++m) L.weight[size_t(m)](y, x) = w[m];
    }
  });
  return L;
}

std::array<cv::Mat4b, 2> splat_maps(const Layers& L) {
  const int H = L.weight[0].rows, W = L.weight[0].cols;
  std::array<cv::Mat4b, 2> out = {cv::Mat4b(H, W), cv::Mat4b(H, W)};
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      int q[kNumMaterials], total = 0;
      float rem[kNumMaterials];
      for (int m = 0; m < kNumMaterials; ++m) {
        const float s = 255.f * L.weight[size_t(m)](y, x);
        q[m] = int(s);
        rem[m] = s - float(q[m]);
        total += q[m];
      }
      // Largest remainders first (ties: the lower material) until the sum is 255.
      for (; total < 255; ++total) {
        int best = 0;
        for (int m = 1; m < kNumMaterials; ++m)
          if (rem[m] > rem[best]) best = m;
        ++q[best];
        rem[best] = -1.f;
      }
      for (int m = 0; m < kNumMaterials; ++m) out[size_t(m / 4)](y, x)[m % 4] = uint8_t(q[m]);
    }
  return out;
}

namespace {
// Lambert-like shade of a unit normal under a sun from the north-west, 45°
// up; the same light in every picture the layers make.
float hill_shade(const cv::Vec3f& normal) {
  const cv::Vec3f sun(-0.5f, 0.5f, float(M_SQRT1_2));
  return std::clamp(0.45f + 0.75f * normal.dot(sun), 0.35f, 1.25f);
}
}  // namespace

const float* material_rgb(int material) {
  static constexpr float kRgb[kNumMaterials][3] = {{32, 52, 92},   {120, 196, 204}, {64, 150, 140}, {228, 212, 164},
                                                   {62, 118, 48},  {112, 100, 92},  {156, 146, 130}, {92, 112, 124}};
  if (material < 0 || material >= kNumMaterials) throw Error("internal: material " + std::to_string(material));
  return kRgb[material];
}

cv::Mat3b material_colour_map(const Layers& L, bool shaded) {
  const float* rgb[kNumMaterials];
  for (int m = 0; m < kNumMaterials; ++m) rgb[m] = material_rgb(m);
  const int H = L.weight[0].rows, W = L.weight[0].cols;
  cv::Mat3b out(H, W);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      float c[3] = {0, 0, 0};
      for (int m = 0; m < kNumMaterials; ++m)
        for (int k = 0; k < 3; ++k) c[k] += L.weight[size_t(m)](y, x) * rgb[m][k];
      const float shade = shaded ? hill_shade(L.normal(y, x)) : 1.0f;
      out(y, x) = cv::Vec3b(cv::saturate_cast<uint8_t>(c[2] * shade), cv::saturate_cast<uint8_t>(c[1] * shade),
                            cv::saturate_cast<uint8_t>(c[0] * shade));  // BGR for OpenCV's writers
    }
  return out;
}

cv::Mat3b flow_colour_map(const Layers& L, const cv::Mat1f& h, double dx) {
  // Drainage below ten cells' area is not a stream yet: nothing is drawn.
  constexpr double kMinCells = 10;
  const double cell = dx * dx;
  double max_area = 0;
  cv::minMaxLoc(L.flow_area_m2, nullptr, &max_area);
  const double span = std::max(1e-9, std::log10(std::max(max_area / cell, kMinCells + 1)) - std::log10(kMinCells));
  cv::Mat3b out(h.size());
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      const float shade = hill_shade(L.normal(y, x));
      cv::Vec3f c = h(y, x) < 0 ? cv::Vec3f(120, 90, 60) : cv::Vec3f(150, 155, 150) * shade;  // BGR
      const double cells = L.flow_area_m2(y, x) / cell;
      if (h(y, x) >= 0 && cells > kMinCells) {
        const float t = float(std::clamp((std::log10(cells) - std::log10(kMinCells)) / span, 0.0, 1.0));
        const cv::Vec3f stream = cv::Vec3f(255, 210, 120) * (1 - t) + cv::Vec3f(200, 70, 0) * t;
        const float a = 0.6f + 0.4f * t;
        c = c * (1 - a) + stream * a;
      }
      out(y, x) = cv::Vec3b(cv::saturate_cast<uint8_t>(c[0]), cv::saturate_cast<uint8_t>(c[1]),
                            cv::saturate_cast<uint8_t>(c[2]));
    }
  return out;
}

cv::Mat3b rain_colour_map(const Layers& L, const cv::Mat1f& h, const cv::Mat1f& rain) {
  if (rain.size() != h.size()) throw Error("rain picture: the rain and the heights must be of one size");
  // The land's driest and wettest (0 and 0 with no land: every cell is sea).
  double dry = 0, wet = 0;
  const cv::Mat land = h > 0;
  if (cv::countNonZero(land) > 0) cv::minMaxLoc(rain, &dry, &wet, nullptr, nullptr, land);
  const double span = std::max(1.0, wet - dry);
  cv::Mat3b out(h.size());
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) {
      const float shade = hill_shade(L.normal(y, x));
      const float t = float(std::clamp((rain(y, x) - dry) / span, 0.0, 1.0));
      const cv::Vec3f land = cv::Vec3f(70, 150, 200) * (1 - t) + cv::Vec3f(150, 140, 30) * t;  // BGR: ochre → teal
      const cv::Vec3f c = h(y, x) <= 0 ? cv::Vec3f(120, 90, 60) : land * (0.35f + 0.65f * shade);
      out(y, x) = cv::Vec3b(cv::saturate_cast<uint8_t>(c[0]), cv::saturate_cast<uint8_t>(c[1]),
                            cv::saturate_cast<uint8_t>(c[2]));
    }
  return out;
}

}  // namespace reefgen::terrain
