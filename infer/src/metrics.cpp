#include "reefgen/infer/metrics.hpp"
#include "reefgen/files.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/labels.hpp"
#include "reefgen/rng.hpp"

namespace reefgen::infer {

using nlohmann::json;

void MetricSums::add(const MetricSums& o) {
  abs_sum += o.abs_sum;
  sq_sum += o.sq_sum;
  pixels += o.pixels;
  for (int r = 0; r < 5; ++r) {
    abs_region[size_t(r)] += o.abs_region[size_t(r)];
    sq_region[size_t(r)] += o.sq_region[size_t(r)];
    px_region[size_t(r)] += o.px_region[size_t(r)];
  }
  ssim_sum += o.ssim_sum;
  slope_w1_sum += o.slope_w1_sum;
  coast_sum += o.coast_sum;
  coast_truth_sum += o.coast_truth_sum;
  pairs += o.pairs;
}

json MetricSums::finish() const {
  auto r4 = [](double v) { return std::round(v * 1e4) / 1e4; };  // stable, readable JSON
  json per_region = json::object();
  for (int r = 0; r < kNumRegions; ++r) {
    const double n = double(std::max<int64_t>(1, px_region[size_t(r)]));
    per_region[kRegionNames[size_t(r)]] = {{"mae_m", r4(abs_region[size_t(r)] / n)},
                            {"rmse_m", r4(std::sqrt(sq_region[size_t(r)] / n))},
                            {"pixel_share", r4(double(px_region[size_t(r)]) / double(std::max<int64_t>(1, pixels)))}};
  }
  const double np = double(std::max<int64_t>(1, pairs));
  return {{"pairs", pairs},
          {"mae_m", r4(abs_sum / double(std::max<int64_t>(1, pixels)))},
          {"rmse_m", r4(std::sqrt(sq_sum / double(std::max<int64_t>(1, pixels))))},
          {"per_region", per_region},
          {"ssim", r4(ssim_sum / np)},
          {"slope_w1_deg", r4(slope_w1_sum / np)},
          {"coastline_agreement", r4(coast_sum / np)},
          {"coastline_agreement_of_truth", r4(coast_truth_sum / np)}};
}

double ssim(const cv::Mat1f& a, const cv::Mat1f& b, double lo, double hi) {
  cv::Mat1f x, y;
  a.convertTo(x, CV_32F, 1.0 / (hi - lo), -lo / (hi - lo));
  b.convertTo(y, CV_32F, 1.0 / (hi - lo), -lo / (hi - lo));
  auto blur = [](const cv::Mat1f& m) {
    cv::Mat1f o;
    cv::GaussianBlur(m, o, {11, 11}, 1.5, 1.5, cv::BORDER_REFLECT);
    return o;
  };
  const cv::Mat1f mx = blur(x), my = blur(y);
  const cv::Mat1f sxx = blur(x.mul(x)) - mx.mul(mx), syy = blur(y.mul(y)) - my.mul(my), sxy = blur(x.mul(y)) - mx.mul(my);
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  double sum = 0;
  for (int r = 0; r < x.rows; ++r)
    for (int c = 0; c < x.cols; ++c) {
      const double ux = mx(r, c), uy = my(r, c);
      sum += ((2 * ux * uy + c1) * (2 * sxy(r, c) + c2)) / ((ux * ux + uy * uy + c1) * (sxx(r, c) + syy(r, c) + c2));
    }
  return sum / double(x.total());
}

namespace {
std::vector<float> slopes_deg(const cv::Mat1f& h, double mpp) {
  cv::Mat1f gx, gy;
  cv::Sobel(h, gx, CV_32F, 1, 0, 3, 1.0 / (8 * mpp), 0, cv::BORDER_REPLICATE);
  cv::Sobel(h, gy, CV_32F, 0, 1, 3, 1.0 / (8 * mpp), 0, cv::BORDER_REPLICATE);
  std::vector<float> s(h.total());
  size_t k = 0;
  for (int r = 0; r < h.rows; ++r)
    for (int c = 0; c < h.cols; ++c) s[k++] = float(std::atan(std::hypot(gx(r, c), gy(r, c))) * 180.0 / M_PI);
  std::sort(s.begin(), s.end());
  return s;
}
}  // namespace

double slope_distance_deg(const cv::Mat1f& a, const cv::Mat1f& b, double mpp) {
  const auto sa = slopes_deg(a, mpp), sb = slopes_deg(b, mpp);
  double sum = 0;
  for (size_t i = 0; i < sa.size(); ++i) sum += std::abs(double(sa[i]) - double(sb[i]));
  return sum / double(sa.size());
}

MetricSums pair_metrics(const cv::Mat1f& pred, const cv::Mat1f& truth, const cv::Mat1b& label, double lo, double hi,
                        double mpp) {
  MetricSums m;
  m.pairs = 1;
  int64_t coast = 0, coast_truth = 0;
  for (int r = 0; r < pred.rows; ++r)
    for (int c = 0; c < pred.cols; ++c) {
      const double d = double(pred(r, c)) - double(truth(r, c));
      const size_t reg = std::min<size_t>(label(r, c), 4);
      m.abs_sum += std::abs(d);
      m.sq_sum += d * d;
      m.abs_region[reg] += std::abs(d);
      m.sq_region[reg] += d * d;
      ++m.px_region[reg];
      const bool land = reg == kIsland || reg == kBeach;
      coast += (pred(r, c) > 0) == land;
      coast_truth += (truth(r, c) > 0) == land;
    }
  m.pixels = int64_t(pred.total());
  m.ssim_sum = ssim(pred, truth, lo, hi);
  m.slope_w1_sum = slope_distance_deg(pred, truth, mpp);
  m.coast_sum = double(coast) / double(m.pixels);
  m.coast_truth_sum = double(coast_truth) / double(m.pixels);
  return m;
}

const char* perturbation_name(Perturbation p) {
  switch (p) {
    case Perturbation::None: return "clean";
    case Perturbation::Blur: return "blur_sigma2";
    case Perturbation::Jpeg50: return "jpeg_q50";
    case Perturbation::HueJitter: return "hue_jitter_15deg";
    case Perturbation::BrushNoise: return "brush_noise";
  }
  return "?";
}

cv::Mat3b perturb(const cv::Mat3b& img, Perturbation p, uint64_t seed) {
  cv::Mat3b out = img.clone();
  Rng rng(derive_seed(seed, uint64_t(p), "perturb"));
  switch (p) {
    case Perturbation::None: break;
    case Perturbation::Blur: cv::GaussianBlur(img, out, {0, 0}, 2.0); break;
    case Perturbation::Jpeg50: {
      std::vector<uint8_t> buf;
      cv::imencode(".jpg", img, buf, {cv::IMWRITE_JPEG_QUALITY, 50});
      out = cv::imdecode(buf, cv::IMREAD_COLOR);
      break;
    }
    case Perturbation::HueJitter: {
      // One shift for the whole sketch, up to ±15°: a painter's slightly-off palette.
      cv::Mat hsv;
      cv::cvtColor(img, hsv, cv::COLOR_BGR2HSV_FULL);
      const int shift = int(std::lround(rng.uniform(-15.0, 15.0) * 256.0 / 360.0));
      for (int r = 0; r < hsv.rows; ++r)
        for (int c = 0; c < hsv.cols; ++c) {
          auto& px = hsv.at<cv::Vec3b>(r, c);
          px[0] = uint8_t((int(px[0]) + shift + 256) % 256);
        }
      cv::cvtColor(hsv, out, cv::COLOR_HSV2BGR_FULL);
      break;
    }
    case Perturbation::BrushNoise: {
      // Rough brush: dabs (radius 1-4 px) of the colour found a few pixels
      // away, so region borders wobble as in a quick hand-drawn sketch.
      const int dabs = int(img.total() / 100);
      for (int k = 0; k < dabs; ++k) {
        const int x = int(rng.uniform_int(0, img.cols - 1)), y = int(rng.uniform_int(0, img.rows - 1));
        const int sx = std::clamp(x + int(rng.uniform_int(-6, 6)), 0, img.cols - 1);
        const int sy = std::clamp(y + int(rng.uniform_int(-6, 6)), 0, img.rows - 1);
        const cv::Vec3b col = img(sy, sx);
        cv::circle(out, {x, y}, int(rng.uniform_int(1, 4)), cv::Scalar(col[0], col[1], col[2]), cv::FILLED, cv::LINE_AA);
      }
      break;
    }
  }
  return out;
}

}  // namespace reefgen::infer

namespace reefgen::infer {

double checkerboard_m(const cv::Mat1f& h) {
  if (h.rows < 2 || h.cols < 2) return 0;
  double sum = 0;
  for (int y = 0; y + 1 < h.rows; ++y) {
    const float* a = h.ptr<float>(y);
    const float* b = h.ptr<float>(y + 1);
    for (int x = 0; x + 1 < h.cols; ++x) sum += std::abs(double(a[x]) - a[x + 1] - b[x] + b[x + 1]);
  }
  return sum / (double(h.rows - 1) * (h.cols - 1));
}

SketchChecks sketch_checks(const cv::Mat1f& pred_m, const DecodedSketch& s, double young_max) {
  if (pred_m.size() != s.label.size()) throw reefgen::Error("sketch_checks: prediction and sketch differ in size");
  SketchChecks c;
  std::vector<float> reef;
  for (int y = 0; y < pred_m.rows; ++y)
    for (int x = 0; x < pred_m.cols; ++x) {
      const int r = s.label(y, x);
      const float h = pred_m(y, x);
      const bool young = s.subsidence(y, x) <= young_max;
      if (r == kReef) reef.push_back(h);
      if (!young) continue;
      if (r == kIsland || r == kBeach) {
        ++c.land_px;
        c.land_above_0 += h > 0;
      } else if (r == kAbyss) {
        ++c.abyss_px;
        c.abyss_below_0 += h < 0;
        c.abyss_below_20 += h < -20;
      }
    }
  if (!reef.empty()) {
    const size_t k = std::min(reef.size() - 1, size_t(0.95 * double(reef.size())));
    std::nth_element(reef.begin(), reef.begin() + long(k), reef.end());
    c.reef_crest_m = reef[k];
  }
  c.checkerboard_m = checkerboard_m(pred_m);
  return c;
}

}  // namespace reefgen::infer
