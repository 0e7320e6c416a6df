#include "reefgen/labels.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <cmath>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/io.hpp"

namespace reefgen {

cv::Vec3b region_rgb(int region, double subsidence) {
  CV_Assert(region >= 0 && region < kNumRegions);
  const double lambda = std::clamp(subsidence, 0.0, 1.0);
  const auto v = static_cast<uint8_t>(std::lround(255.0 * subsidence_to_value(lambda)));
  switch (region) {
    case kIsland: return {v, v, 0};
    case kBeach: return {0, v, 0};
    case kLagoon: return {0, v, v};
    case kReef: return {0, 0, v};
    default: return {v, 0, 0};
  }
}

cv::Mat3b encode_labels(const cv::Mat1b& label, const cv::Mat1f& subsidence) {
  CV_Assert(label.size() == subsidence.size());
  cv::Mat3b out(label.size());
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < label.cols; ++x) {
      const uint8_t id = label(y, x);
      if (id >= kNumRegions) throw Error("label value " + std::to_string(id) + " is not a region id (0..4)");
      const cv::Vec3b rgb = region_rgb(id, subsidence(y, x));
      out(y, x) = {rgb[2], rgb[1], rgb[0]};
    }
  return out;
}

cv::Mat3b encode_labels(const cv::Mat1b& label, double subsidence) {
  // One colour per region: a 5-entry lookup instead of per-pixel conversion.
  std::array<cv::Vec3b, kNumRegions> lut;
  for (int i = 0; i < kNumRegions; ++i) {
    const cv::Vec3b rgb = region_rgb(i, subsidence);
    lut[i] = {rgb[2], rgb[1], rgb[0]};
  }
  cv::Mat3b out(label.size());
  for (int y = 0; y < label.rows; ++y) {
    const uint8_t* src = label.ptr<uint8_t>(y);
    cv::Vec3b* dst = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < label.cols; ++x) {
      if (src[x] >= kNumRegions) throw Error("label value " + std::to_string(src[x]) + " is not a region id (0..4)");
      dst[x] = lut[src[x]];
    }
  }
  return out;
}

namespace {

// Nearest region hue on the circle; ties at 300° (magenta) go to the abyss.
int nearest_region(double hue_deg) {
  int best = kAbyss;
  double best_d = 1e9;
  for (int r : {kAbyss, kIsland, kBeach, kLagoon, kReef}) {
    double d = std::fabs(hue_deg - region_hue_deg(r));
    d = std::min(d, 360.0 - d);
    if (d < best_d) { best_d = d; best = r; }
  }
  return best;
}

}  // namespace

DecodedSketch decode_sketch(const cv::Mat& image, const std::string& name) {
  if (image.empty()) throw Error(name + ": empty image");
  const int ch = image.channels();
  if (ch != 1 && ch != 3 && ch != 4)
    throw Error(name + ": " + std::to_string(ch) + " channels; expected grey, RGB or RGBA");
  double scale = 1.0;
  switch (image.depth()) {
    case CV_8U: scale = 1.0 / 255.0; break;
    case CV_16U: scale = 1.0 / 65535.0; break;
    case CV_32F: scale = 1.0; break;
    default: throw Error(name + ": unsupported pixel depth (use 8- or 16-bit PNG/JPEG)");
  }
  cv::Mat f;
  image.convertTo(f, CV_32F, scale);

  DecodedSketch out;
  out.label.create(image.size());
  out.subsidence.create(image.size());
  out.ruggedness.create(image.size());
  // Pixels without a usable hue are marked 255 and filled afterwards.
  cv::Mat1b unknown(image.size(), uint8_t(0));
  int known = 0;
  for (int y = 0; y < f.rows; ++y) {
    const float* p = f.ptr<float>(y);
    for (int x = 0; x < f.cols; ++x, p += ch) {
      float b, g, r, a = 1.f;
      if (ch == 1) { b = g = r = p[0]; }
      else { b = p[0]; g = p[1]; r = p[2]; if (ch == 4) a = p[3]; }
      if (!(std::isfinite(b) && std::isfinite(g) && std::isfinite(r)))
        throw Error(name + ": pixel (" + std::to_string(x) + "," + std::to_string(y) + ") is NaN or infinite");
      if (a < 0.5f) {  // unpainted (transparent) canvas is open ocean
        out.label(y, x) = kAbyss; out.subsidence(y, x) = 0.f; out.ruggedness(y, x) = 255; ++known;
        continue;
      }
      const float mx = std::max({r, g, b}), mn = std::min({r, g, b});
      const float chroma = mx - mn;
      out.subsidence(y, x) = std::clamp((1.f - mx) / 0.75f, 0.f, 1.f);
      // Below this chroma the hue is noise (JPEG ringing on grey, a black line).
      if (chroma < 0.06f || chroma < 0.15f * mx) { unknown(y, x) = 255; out.label(y, x) = 0; continue; }
      const float rugged = (chroma / mx - kSmoothSaturation) / (kRuggedSaturation - kSmoothSaturation);
      out.ruggedness(y, x) = static_cast<uint8_t>(std::lround(255.f * std::clamp(rugged, 0.f, 1.f)));
      double h;
      if (mx == r) h = 60.0 * std::fmod((g - b) / chroma + 6.0, 6.0);
      else if (mx == g) h = 60.0 * ((b - r) / chroma + 2.0);
      else h = 60.0 * ((r - g) / chroma + 4.0);
      out.label(y, x) = static_cast<uint8_t>(nearest_region(h));
      ++known;
    }
  }
  if (known == 0)
    throw Error(name + ": no pixel has a region colour (paint with red abyss, blue reef, cyan lagoon, green beach, yellow island)");
  out.filled_px = static_cast<int>(f.total()) - known;
  if (out.filled_px > 0) {
    // distanceTransform with DIST_LABEL_PIXEL gives each pixel the index of its
    // nearest zero (= known) pixel; indices follow row-major order from 1.
    cv::Mat1f dist;
    cv::Mat1i nearest;
    cv::distanceTransform(unknown, dist, nearest, cv::DIST_L2, cv::DIST_MASK_5, cv::DIST_LABEL_PIXEL);
    std::vector<cv::Point> seeds;
    seeds.reserve(known);
    for (int y = 0; y < unknown.rows; ++y)
      for (int x = 0; x < unknown.cols; ++x)
        if (!unknown(y, x)) seeds.emplace_back(x, y);
    for (int y = 0; y < unknown.rows; ++y)
      for (int x = 0; x < unknown.cols; ++x)
        if (unknown(y, x)) {
          const cv::Point s = seeds.at(nearest(y, x) - 1);
          out.label(y, x) = out.label(s.y, s.x);
          out.subsidence(y, x) = out.subsidence(s.y, s.x);
          out.ruggedness(y, x) = out.ruggedness(s.y, s.x);
        }
  }
  return out;
}

namespace {
// The most a sketch file may hold (read_image's bound): far above any
// 8192² PNG, far below what a mistaken path to a disk image would be.
constexpr size_t kMaxSketchBytes = size_t(256) << 20;

// Width and height from a PNG's IHDR (bytes 16..23), or {0,0} if not a PNG:
// checked before decoding, so a 30000² file is refused instead of taking 10 GB.
std::pair<uint32_t, uint32_t> png_size(const std::string& bytes) {
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const size_t n = bytes.size();
  static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n < 24 || std::memcmp(b, sig, 8) != 0) return {0, 0};
  auto be32 = [&](int at) { return uint32_t(b[at]) << 24 | uint32_t(b[at + 1]) << 16 | uint32_t(b[at + 2]) << 8 | b[at + 3]; };
  return {be32(16), be32(20)};
}
}  // namespace

DecodedSketch read_sketch(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) throw Error("cannot read " + path.string() + ": no such file");
  const auto too_big = [&](uint64_t w, uint64_t h) {
    return Error("cannot read " + path.string() + ": " + std::to_string(w) + "×" + std::to_string(h) +
                 " pixels; sketches may be at most " + std::to_string(kMaxSketchSide) + " pixels a side (scale it down)");
  };
  // Read once: a pipe (a shell's <(...)) cannot be read twice.
  const std::string bytes = read_text(path, kMaxSketchBytes);
  const auto [pw, ph] = png_size(bytes);
  if (pw > uint32_t(kMaxSketchSide) || ph > uint32_t(kMaxSketchSide)) throw too_big(pw, ph);
  const cv::Mat img = decode_image(bytes, path.string(), cv::IMREAD_UNCHANGED);
  if (img.cols > kMaxSketchSide || img.rows > kMaxSketchSide) throw too_big(uint64_t(img.cols), uint64_t(img.rows));
  return decode_sketch(img, path.string());
}

}  // namespace reefgen
