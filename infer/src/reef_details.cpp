#include "reefgen/infer/reef_details.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "reefgen/labels.hpp"
#include "reefgen/ramp.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/terrain/noise.hpp"

#include "regions.hpp"

namespace reefgen::infer {

namespace {

// The generator's sizes (procgen/src/reef.cpp add_random_passes,
// add_random_motu): passes 100–260 m wide, 8–20 m deep, within ±60° of
// leeward; motu 150–1200 m long, 150–400 m wide, kept 0.15 rad off a pass.
constexpr double kPassWidthM[2] = {100, 260}, kPassDepthM[2] = {8, 20};
constexpr double kMotuLenM[2] = {150, 1200}, kMotuWidM[2] = {150, 400};
constexpr double kLeewardSpread = M_PI / 3, kMotuPassGap = 0.15;
// Where across the ring each sits, as the share t of the way from the sea
// (0) to the lagoon (1): a pass is centred mid-ring, a motu on the reef flat
// behind the crest (reef_finish: crest at t 0.22–0.32, flat to 0.5).
constexpr double kPassT = 0.5, kMotuT = 0.62, kTTolerance = 0.15;
// A motu is at most this share of its ring's width across, and a ring
// narrower than kMinMotuRingPx cells gets none (too thin to hold one).
constexpr double kMotuRingShare = 0.6, kMinMotuRingPx = 3;
// Places tried for each motu before it is given up (it would meet a pass or
// another motu, or the ring is too thin there).
constexpr int kMotuAttempts = 4;
// A painted islet on a ring: no larger than reef_finish's largest motu.
constexpr double kIsletMaxAreaM2 = 2e6;
// A pass reaches this many cells past the ring on either side, so the fore
// reef the network drew beyond the painted band is cut too.
constexpr double kPassOverhangPx = 3;
// A pass winds: its bends' wavelength and amplitude, in pass widths.
constexpr double kPassWaveWidths[2] = {4, 7}, kPassBendWidths[2] = {0.5, 1.0};
// Features of the pass floor's unevenness, metres.
constexpr double kPassFloorFeatureM = 80;
// The pass's walls wander by this share of its half-width, with features of
// kPassWallFeatureM (coral spurs and embayments along a real pass).
constexpr double kPassWallWander = 0.35, kPassWallFeatureM = 50;

struct Ring {
  std::vector<int> cells;  // indices y·W + x
  cv::Point2d centroid;    // px
  bool lagoon_behind = false, painted_pass = false, painted_islets = false;
  double subsidence = 1, width_px = 0, length_m = 0;
};

double angle_gap(double a, double b) { return std::fabs(std::remainder(a - b, 2.0 * M_PI)); }

// Which lagoon components touch the open sea directly: a painted gap in the
// ring, that is a painted pass.
std::vector<uint8_t> open_lagoons(const cv::Mat1b& label, const cv::Mat1i& lagoon_comp, int n) {
  std::vector<uint8_t> open(size_t(n), 0);
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < label.cols; ++x) {
      if (label(y, x) != kLagoon) continue;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int yy = y + dy, xx = x + dx;
          if (yy >= 0 && xx >= 0 && yy < label.rows && xx < label.cols && label(yy, xx) == kAbyss)
            open[size_t(lagoon_comp(y, x))] = 1;
        }
    }
  return open;
}

// The painted islets of a ring: small land (reef_finish's largest motu)
// touching reef, wherever else it reaches (an islet painted across the
// whole band meets lagoon and sea too). 255 on their cells.
cv::Mat1b painted_islets(const cv::Mat1b& label, double mpp) {
  cv::Mat1i comp;
  const int n = cv::connectedComponents(cv::Mat1b((label == kIsland) | (label == kBeach)), comp, 8, CV_32S);
  std::vector<int64_t> area(size_t(n), 0);
  std::vector<uint8_t> on_reef(size_t(n), 0);
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < label.cols; ++x) {
      if (landlike(label(y, x))) {
        ++area[size_t(comp(y, x))];
        continue;
      }
      if (label(y, x) != kReef) continue;
      // A reef cell: every islet beside it touches reef.
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int yy = y + dy, xx = x + dx;
          if (yy >= 0 && xx >= 0 && yy < label.rows && xx < label.cols && landlike(label(yy, xx)))
            on_reef[size_t(comp(yy, xx))] = 1;
        }
    }
  std::vector<uint8_t> islet(size_t(n), 0);
  for (int c = 1; c < n; ++c)
    islet[size_t(c)] = double(area[size_t(c)]) * mpp * mpp <= kIsletMaxAreaM2 && on_reef[size_t(c)];
  cv::Mat1b out(label.size(), uint8_t(0));
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < label.cols; ++x)
      if (islet[size_t(comp(y, x))]) out(y, x) = 255;
  return out;
}

// A ring's length along its middle: half the length of all its edges (the
// outer and the inner edge of a closed rim, both sides of an open bank).
double ring_length_m(const Ring& ring, int W, double mpp) {
  int x0 = W, y0 = 1 << 30, x1 = 0, y1 = 0;
  for (int i : ring.cells) x0 = std::min(x0, i % W), x1 = std::max(x1, i % W), y0 = std::min(y0, i / W), y1 = std::max(y1, i / W);
  // One cell of margin, so an edge on the box's border is still an edge.
  const cv::Rect box(x0 - 1, y0 - 1, x1 - x0 + 3, y1 - y0 + 3);
  cv::Mat1b mask(box.size(), uint8_t(0));
  for (int i : ring.cells) mask(i / W - box.y, i % W - box.x) = 255;
  std::vector<std::vector<cv::Point>> edges;
  cv::findContours(mask, edges, cv::RETR_LIST, cv::CHAIN_APPROX_SIMPLE);
  double px = 0;
  for (const auto& e : edges) px += cv::arcLength(e, true);
  return 0.5 * px * mpp;
}

// The painted reef rings, with what the painting already shows on each.
std::vector<Ring> find_rings(const cv::Mat1b& label, const cv::Mat1f& subsidence, double mpp, const cv::Mat1f& d_in,
                             const cv::Mat1f& d_out) {
  const int W = label.cols;
  // A ring is its reef and the islets on it: painted motu that span the
  // band do not cut it into rings of their own.
  const cv::Mat1b islets = painted_islets(label, mpp);
  cv::Mat1i reef_comp;
  const int n = cv::connectedComponents(cv::Mat1b((label == kReef) | islets), reef_comp, 8, CV_32S);
  cv::Mat1i lagoon_comp;
  const int nl = cv::connectedComponents(cv::Mat1b(label == kLagoon), lagoon_comp, 8, CV_32S);
  const std::vector<uint8_t> open = open_lagoons(label, lagoon_comp, nl);
  std::vector<Ring> rings(static_cast<size_t>(n));
  std::vector<double> lambda(size_t(n), 0.0);
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < W; ++x) {
      const int r = reef_comp(y, x);
      if (r == 0) continue;
      Ring& ring = rings[size_t(r)];
      if (islets(y, x)) {
        ring.painted_islets = true;
        continue;
      }
      ring.cells.push_back(y * W + x);
      ring.centroid += cv::Point2d(x + 0.5, y + 0.5);
      lambda[size_t(r)] += subsidence.empty() ? 1.0 : double(subsidence(y, x));
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int yy = y + dy, xx = x + dx;
          if (yy < 0 || xx < 0 || yy >= label.rows || xx >= W || label(yy, xx) != kLagoon) continue;
          ring.lagoon_behind = true;
          if (open[size_t(lagoon_comp(yy, xx))]) ring.painted_pass = true;
        }
    }
  for (int r = 1; r < n; ++r) {
    Ring& ring = rings[size_t(r)];
    if (ring.cells.empty()) continue;  // islets alone
    const double cells = double(ring.cells.size());
    ring.centroid /= cells;
    ring.subsidence = lambda[size_t(r)] / cells;
    // Its width: twice the deepest a cell lies inside it.
    for (int i : ring.cells) ring.width_px = std::max(ring.width_px, 2.0 * std::min(d_in(i / W, i % W), d_out(i / W, i % W)));
    ring.width_px = std::max(ring.width_px, 1.0);
    ring.length_m = ring_length_m(ring, W, mpp);
  }
  return rings;
}

// The ring's cell closest in angle (seen from its centroid) to theta among
// those at t = want ± kTTolerance (t: d_out / (d_in + d_out)); -1 if none.
int cell_towards(const Ring& ring, double theta, double want, const cv::Mat1f& d_in, const cv::Mat1f& d_out, int W) {
  int best = -1;
  double gap = 1e9;
  for (int i : ring.cells) {
    const int y = i / W, x = i % W;
    const double t = d_out(y, x) / std::max(1e-6, double(d_in(y, x) + d_out(y, x)));
    if (std::fabs(t - want) > kTTolerance) continue;
    const double g = angle_gap(std::atan2(y + 0.5 - ring.centroid.y, x + 0.5 - ring.centroid.x), theta);
    if (g < gap) gap = g, best = i;
  }
  return best;
}

// Unit vector from the lagoon towards the sea at a cell: down the gradient
// of d_out − d_in (smoothed), or away from the ring's centroid.
cv::Point2d seaward(const cv::Mat1f& across, const Ring& ring, int y, int x) {
  const int W = across.cols, H = across.rows;
  const double gx = across(y, std::min(x + 1, W - 1)) - across(y, std::max(x - 1, 0));
  const double gy = across(std::min(y + 1, H - 1), x) - across(std::max(y - 1, 0), x);
  cv::Point2d u(-gx, -gy);
  if (std::hypot(u.x, u.y) < 1e-3) u = cv::Point2d(x + 0.5, y + 0.5) - ring.centroid;
  const double l = std::hypot(u.x, u.y);
  return l > 0 ? u / l : cv::Point2d(1, 0);
}

// A pass's centre line from a to b (metres): a point every half-width,
// an odd count so the middle one sits mid-ring, each pushed sideways by two
// sines of the seed's own (wavelengths 4–7 widths and 0.4–0.6 of that,
// amplitude 0.5–1 width): a channel that winds across the reef flat as
// real passes do, however wide the ring (two bends on a narrow ring, a
// meander across a wide one; a straight cut read as a canal at 1:1).
std::vector<cv::Point2d> winding_path(const cv::Point2d& a, const cv::Point2d& b, const cv::Point2d& side,
                                      double width, Rng& rng) {
  const double length = std::hypot(b.x - a.x, b.y - a.y);
  const int half = std::max(2, int(std::ceil(length / width)));
  const double wave = rng.uniform(kPassWaveWidths[0], kPassWaveWidths[1]) * width;
  const double wave2 = wave * rng.uniform(0.4, 0.6);
  const double phase = rng.uniform(0, 2 * M_PI), phase2 = rng.uniform(0, 2 * M_PI);
  const double amp = rng.uniform(kPassBendWidths[0], kPassBendWidths[1]) * width / 1.5;
  std::vector<cv::Point2d> path;
  for (int j = 0; j <= 2 * half; ++j) {
    const double f = double(j) / (2 * half), s = f * length;
    const double off = amp * (std::sin(2 * M_PI * s / wave + phase) + 0.5 * std::sin(2 * M_PI * s / wave2 + phase2));
    path.push_back(a + (b - a) * f + side * off);
  }
  return path;
}

void plan_passes(const Ring& ring, double leeward, Rng& rng, const cv::Mat1f& d_in, const cv::Mat1f& d_out,
                 const cv::Mat1f& across, double mpp, SeededReefDetails& out) {
  const int W = d_in.cols;
  const int count = ring.length_m < kTwoPassRingM ? 1 : kSeededPasses;
  for (int k = 0; k < count; ++k) {
    const double theta = leeward + rng.uniform(-kLeewardSpread, kLeewardSpread);
    const double width = rng.uniform(kPassWidthM[0], kPassWidthM[1]), depth = rng.uniform(kPassDepthM[0], kPassDepthM[1]);
    const int i = cell_towards(ring, theta, kPassT, d_in, d_out, W);
    if (i < 0) continue;
    const int y = i / W, x = i % W;
    const cv::Point2d p(x + 0.5, y + 0.5), u = seaward(across, ring, y, x), side(-u.y, u.x);
    const cv::Point2d a = p - u * (d_in(y, x) + kPassOverhangPx), b = p + u * (d_out(y, x) + kPassOverhangPx);
    SeededReefDetails::Pass pass;
    pass.width_m = width;
    pass.depth_m = depth;
    pass.path_m = winding_path(a * mpp, b * mpp, side, width, rng);
    out.passes.push_back(std::move(pass));
  }
}

// One motu towards theta, or false when the ring is too thin there or it
// would meet a pass or another motu.
bool place_islet(const Ring& ring, double theta, Rng& rng, const cv::Mat1f& d_in, const cv::Mat1f& d_out,
                 const cv::Mat1f& across, double mpp, const SeededReefDetails& out, size_t first_pass,
                 size_t first_motu, SeededReefDetails::Islet& m) {
  const int W = d_in.cols;
  const double len = rng.uniform(kMotuLenM[0], kMotuLenM[1]), wid = rng.uniform(kMotuWidM[0], kMotuWidM[1]);
  const int i = cell_towards(ring, theta, kMotuT, d_in, d_out, W);
  if (i < 0) return false;
  const int y = i / W, x = i % W;
  // The ring's width here: a motu fills at most kMotuRingShare of it, so the crest stays seaward of it.
  const double width_px = d_in(y, x) + d_out(y, x);
  if (width_px < kMinMotuRingPx) return false;
  const cv::Point2d c = cv::Point2d(x + 0.5, y + 0.5) * mpp;
  const double ring_r_m = std::hypot(x + 0.5 - ring.centroid.x, y + 0.5 - ring.centroid.y) * mpp;
  m.centre_m = c;
  const cv::Point2d u = seaward(across, ring, y, x);
  m.angle_rad = std::atan2(u.x, -u.y);  // along the ring: u turned a quarter
  m.half_wid_m = std::min(0.5 * wid, 0.5 * kMotuRingShare * width_px * mpp);
  // Straight, so no longer than what stays within a quarter of the ring's
  // width of its curve (sagitta l²/2R ≤ width/4).
  m.half_len_m = std::max(m.half_wid_m, std::min(0.5 * len, std::sqrt(0.5 * ring_r_m * width_px * mpp)));
  for (size_t j = first_pass; j < out.passes.size(); ++j) {
    const cv::Point2d mid = out.passes[j].middle_m();
    const double pass_theta = std::atan2(mid.y / mpp - ring.centroid.y, mid.x / mpp - ring.centroid.x);
    if (angle_gap(theta, pass_theta) < kMotuPassGap ||
        std::hypot(mid.x - c.x, mid.y - c.y) <= m.half_len_m + out.passes[j].width_m)
      return false;
  }
  for (size_t j = first_motu; j < out.motu.size(); ++j)
    if (std::hypot(out.motu[j].centre_m.x - c.x, out.motu[j].centre_m.y - c.y) <= m.half_len_m + out.motu[j].half_len_m)
      return false;
  return true;
}

void plan_motu(const Ring& ring, Rng& rng, const cv::Mat1f& d_in, const cv::Mat1f& d_out, const cv::Mat1f& across,
               double mpp, SeededReefDetails& out, size_t first_pass) {
  if (ring.width_px < kMinMotuRingPx) return;
  const double share = std::min(1.0, ring.subsidence / kMotuFullSubsidence);
  const int count = int(std::lround(kSeededMotuPerM * ring.length_m * share));
  const size_t first_motu = out.motu.size();
  for (int k = 0; k < count; ++k)
    for (int attempt = 0; attempt < kMotuAttempts; ++attempt) {
      SeededReefDetails::Islet m;
      if (!place_islet(ring, rng.uniform(-M_PI, M_PI), rng, d_in, d_out, across, mpp, out, first_pass, first_motu, m))
        continue;
      out.motu.push_back(m);
      break;
    }
}

}  // namespace

SeededReefDetails plan_reef_details(const cv::Mat1b& label, const cv::Mat1f& subsidence, double metres_per_px,
                                    uint64_t seed, double variation) {
  SeededReefDetails out;
  if (!(variation > 0) || label.empty()) return out;
  cv::Mat1f lambda;
  if (!subsidence.empty()) cv::resize(subsidence, lambda, label.size(), 0, 0, cv::INTER_AREA);
  // Capped beyond any distance on the canvas (a canvas without open sea or lagoon reads the cap).
  const float far = float(label.rows + label.cols);
  const cv::Mat1f d_in = distance_to((label == kLagoon) | (label == kIsland) | (label == kBeach), far);
  const cv::Mat1f d_out = distance_to(cv::Mat1b(label == kAbyss), far);
  cv::Mat1f across = d_out - d_in;
  cv::GaussianBlur(across, across, cv::Size(0, 0), 1.0, 1.0, cv::BORDER_REPLICATE);
  const std::vector<Ring> rings = find_rings(label, lambda, metres_per_px, d_in, d_out);
  // One wind for the canvas (a painting has no wind strokes): the generator
  // draws its windward side at random when none is given.
  Rng wind(seed, 0, "painted-reef-windward");
  const double leeward = wind.uniform(0, 2.0 * M_PI) + M_PI;
  for (size_t r = 1; r < rings.size(); ++r) {
    const Ring& ring = rings[r];
    if (!ring.lagoon_behind) continue;
    Rng rng(seed, r, "painted-reef-details");
    const size_t first_pass = out.passes.size();
    if (!ring.painted_pass) plan_passes(ring, leeward, rng, d_in, d_out, across, metres_per_px, out);
    if (!ring.painted_islets) plan_motu(ring, rng, d_in, d_out, across, metres_per_px, out, first_pass);
  }
  return out;
}

void paint_seeded_motu(cv::Mat1b& label, const SeededReefDetails& d, double metres_per_px) {
  for (const auto& m : d.motu) {
    const double reach = m.half_len_m / metres_per_px + 1;
    const double cx = m.centre_m.x / metres_per_px, cy = m.centre_m.y / metres_per_px;
    const double ca = std::cos(m.angle_rad), sa = std::sin(m.angle_rad);
    for (int y = std::max(0, int(cy - reach)); y <= std::min(label.rows - 1, int(cy + reach)); ++y)
      for (int x = std::max(0, int(cx - reach)); x <= std::min(label.cols - 1, int(cx + reach)); ++x) {
        if (label(y, x) != kReef) continue;
        const double px = (x + 0.5) * metres_per_px - m.centre_m.x, py = (y + 0.5) * metres_per_px - m.centre_m.y;
        const double along = px * ca + py * sa, across = -px * sa + py * ca;
        if (along * along / (m.half_len_m * m.half_len_m) + across * across / (m.half_wid_m * m.half_wid_m) <= 1.0)
          label(y, x) = kBeach;
      }
  }
}

namespace {
// Distance (m) from p to a polyline.
double to_path(const std::vector<cv::Point2d>& path, const cv::Point2d& p) {
  double best = 1e30;
  for (size_t i = 0; i + 1 < path.size(); ++i) {
    const cv::Point2d a = path[i], ab = path[i + 1] - a, ap = p - a;
    const double l2 = ab.dot(ab);
    const double t = l2 > 0 ? std::clamp(ap.dot(ab) / l2, 0.0, 1.0) : 0.0;
    const cv::Point2d e = ap - ab * t;
    best = std::min(best, std::hypot(e.x, e.y));
  }
  return best;
}
}  // namespace

void cut_seeded_passes(cv::Mat1f& h, const cv::Mat1b& label, const SeededReefDetails& d, double metres_per_px,
                       uint64_t seed) {
  if (d.passes.empty() || h.empty()) return;
  cv::Mat1b lab = label;
  if (lab.size() != h.size()) cv::resize(label, lab, h.size(), 0, 0, cv::INTER_NEAREST);
  const terrain::GradientNoise2 noise(derive_seed(seed, 0, "seeded-pass-floor"));
  for (const auto& p : d.passes) {
    const double hw = 0.5 * p.width_m, reach = (1.3 + kPassWallWander) * hw;
    double x0 = 1e30, y0 = 1e30, x1 = -1e30, y1 = -1e30;
    for (const auto& q : p.path_m) x0 = std::min(x0, q.x), y0 = std::min(y0, q.y), x1 = std::max(x1, q.x), y1 = std::max(y1, q.y);
    const int c0 = std::max(0, int((x0 - reach) / metres_per_px)), c1 = std::min(h.cols - 1, int((x1 + reach) / metres_per_px));
    const int r0 = std::max(0, int((y0 - reach) / metres_per_px)), r1 = std::min(h.rows - 1, int((y1 + reach) / metres_per_px));
    for (int y = r0; y <= r1; ++y)
      for (int x = c0; x <= c1; ++x) {
        if (landlike(lab(y, x))) continue;
        const cv::Point2d c((x + 0.5) * metres_per_px, (y + 0.5) * metres_per_px);
        const double dist = to_path(p.path_m, c);
        if (dist >= reach) continue;
        const float n = noise.fbm(float(c.x / kPassFloorFeatureM), float(c.y / kPassFloorFeatureM), 2);
        const float floor = -float(p.depth_m) * (1.f + 0.15f * std::clamp(n, -1.f, 1.f));
        // Coral-lined walls wander: the half-width varies by ±kPassWallWander
        // along the pass, so the cut is no straight-sided slot.
        const float wall = noise.fbm(float(c.x / kPassWallFeatureM) + 57.3f, float(c.y / kPassWallFeatureM) + 19.1f, 2);
        const double hw_here = hw * (1.0 + kPassWallWander * std::clamp(double(wall) * 2.0, -1.0, 1.0));
        const float keep = ramp(0.5 * hw_here, 1.0 * hw_here + 0.3 * hw, dist);
        h(y, x) += (1.f - keep) * (std::min(h(y, x), floor) - h(y, x));
      }
  }
}

}  // namespace reefgen::infer
