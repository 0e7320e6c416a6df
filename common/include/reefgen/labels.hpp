#pragma once
// The HSV label encoding of the paper (docs/DESIGN.md §2):
//   hue = region: island 60° (yellow), beach 120° (green), lagoon 180° (cyan),
//         reef 240° (blue), abyss 0° (red);
//   value = 1 − 0.75·λ, λ the subsidence in [0,1] (V ≥ 0.25 keeps the hue);
//   saturation = 1.
#include <array>
#include <cstdint>
#include <filesystem>

#include <opencv2/core.hpp>

namespace reefgen {

enum Region : uint8_t { kIsland = 0, kBeach = 1, kLagoon = 2, kReef = 3, kAbyss = 4 };
inline constexpr int kNumRegions = 5;
// Region 0 is "island" everywhere (the paper's name; the yellow brush paints
// the mountain of it): sidecars, stats.json, eval's per_region keys.
inline constexpr std::array<const char*, kNumRegions> kRegionNames = {"island", "beach", "lagoon", "reef", "abyss"};

// Hue in degrees of a region id (0..4).
constexpr double region_hue_deg(int region) { return region == kAbyss ? 0.0 : 60.0 * (region + 1); }
// HSV value for a subsidence λ in [0,1].
constexpr double subsidence_to_value(double lambda) { return 1.0 - 0.75 * lambda; }

// RGB (not BGR) 8-bit colour of a region at subsidence λ.
cv::Vec3b region_rgb(int region, double subsidence);

// Label ids (CV_8U, 0..4) → 8-bit BGR image (OpenCV order, ready for write_png).
cv::Mat3b encode_labels(const cv::Mat1b& label, double subsidence);
cv::Mat3b encode_labels(const cv::Mat1b& label, const cv::Mat1f& subsidence);

// A label sketch as the island systems make it (procgen's random sketches,
// islands' height bands): regions and subsidence per pixel.
struct Sketch {
  cv::Mat1b label;       // region ids 0..4
  cv::Mat1f subsidence;  // λ per pixel (the island's; abyss takes the nearest island's)
};

struct DecodedSketch {
  cv::Mat1b label;       // region ids 0..4
  cv::Mat1f subsidence;  // λ per pixel in [0,1]
  int filled_px = 0;     // grey/black/white pixels whose region came from the nearest coloured pixel
  // Per-region style from the colour's saturation (the paper's reserved
  // channel; docs/INFERENCE.md "Per-region style"): 255 = rugged (the
  // palette's full colours, and every pixel of a sketch painted with them),
  // 0 = a smooth shield (pastel, saturation ≤ kSmoothSaturation). Empty =
  // rugged everywhere.
  cv::Mat1b ruggedness;
};
// Saturation (chroma / max) at and above which a colour is fully rugged
// (the palette's 1.0, with room for JPEG and anti-aliasing), and at and below
// which it is a smooth shield; linear between.
inline constexpr float kRuggedSaturation = 0.85f;
inline constexpr float kSmoothSaturation = 0.35f;

// Tolerant decoding of a painted sketch: 8- or 16-bit, 1, 3 (BGR) or 4 (BGRA)
// channels. The region is the nearest of the five hues on the colour circle
// whatever the saturation and value; pixels without a usable hue (grey, white,
// near-black: anti-aliasing towards a background) take the region of the
// nearest coloured pixel; transparent pixels (alpha < 50 %) are abyss.
// Throws Error when no pixel carries a region colour.
DecodedSketch decode_sketch(const cv::Mat& image, const std::string& name = "sketch");
// Sketches larger than this a side are refused (a PNG before decoding: memory).
inline constexpr int kMaxSketchSide = 8192;
// Reads any image OpenCV can read (PNG, JPEG, TIFF, ...), keeping depth and alpha.
DecodedSketch read_sketch(const std::filesystem::path& path);

}  // namespace reefgen
