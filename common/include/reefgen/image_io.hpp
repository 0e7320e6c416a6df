#pragma once
// Images and height fields on disk: user images read defensively, PNG
// written fast and reproducibly, float heights in OpenEXR (whole or a band
// of rows at a time); every write atomic (reefgen/files.hpp).
#include <algorithm>
#include <cctype>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/files.hpp"

namespace reefgen {

// Reads an image a user gave (sketch, painting, label): refuses a missing
// file, a folder, more than 256 MiB, and PNG/JPEG files that are truncated or
// damaged (chunk CRCs, end markers) before OpenCV decodes them, so a cut
// download is an error naming the file, not a half-grey sketch and libpng's
// chatter on stderr. `flags` as cv::imread. Throws Error naming the file.
// The side is checked from the file's header before anything is decoded
// (a 2.6 MB PNG may declare 30000² pixels: 2.7 GB decoded): larger than
// `max_side` on either axis is an Error naming the size and the limit.
cv::Mat read_image(const fs::path& path, int flags, int max_side = kMaxImageSidePx);
// The same for bytes already in memory (`name` for messages).
cv::Mat decode_image(const std::string& bytes, const std::string& name, int flags, int max_side = kMaxImageSidePx);
// The width and height an image's header declares (PNG, JPEG, BMP, WebP,
// TIFF, PNM); {0, 0} when the format is not one of them or the header is
// cut (decode_image then refuses it: nothing would bound its decoding).
cv::Size declared_image_size(const std::string& bytes);
// "" when bytes look like a complete PNG/JPEG (or another format), else what is wrong.
std::string image_damage(const std::string& bytes);

// 8-bit (CV_8UC3 BGR or CV_8UC1) or 16-bit PNG, lossless, written atomically.
// `level` is zlib's 0..9: 1 is several times faster and ~10 % larger (datasets).
void write_png(const fs::path& path, const cv::Mat& image, int level = 6);
// The bytes of an 8-bit grey, BGR or BGRA PNG (what write_png writes for those).
std::string encode_png8(const cv::Mat& image, int level = 6);
// The same for 16-bit grey, BGR or BGRA (samples big-endian, as PNG stores them).
std::string encode_png16(const cv::Mat& image, int level = 6);

// Single-channel float32 OpenEXR with channel "Y" (heights in metres) and
// string attributes (e.g. "reefgen:json" holding the sidecar). ZIP compressed
// at `zip_level` (1..9); 0 writes it uncompressed.
using ExrAttributes = std::map<std::string, std::string>;
void write_exr_height(const fs::path& path, const cv::Mat1f& height_m, const ExrAttributes& attrs = {},
                      int zip_level = 6);
// The same with another channel name: Godot's EXR loader takes "R" as a
// one-channel float image (Image::FORMAT_RF), "Y" as grey RGB.
void write_exr_channel(const fs::path& path, const cv::Mat1f& values, const std::string& channel,
                       const ExrAttributes& attrs = {}, int zip_level = 6);
// Reads channel "Y" (or the only channel) of an EXR file; attributes of string
// type are returned in `attrs` when not null. A side past `max_side` (read
// from the header, before anything is allocated) is an Error naming it.
cv::Mat1f read_exr_height(const fs::path& path, ExrAttributes* attrs = nullptr, int max_side = kMaxFieldSidePx);
// The same field read a band of rows at a time (a world larger than memory):
// size and attributes from the header, rows(y0, n) the rows y0 … y0 + n − 1.
class ExrRowReader {
 public:
  explicit ExrRowReader(const fs::path& path);
  ~ExrRowReader();
  ExrRowReader(const ExrRowReader&) = delete;
  ExrRowReader& operator=(const ExrRowReader&) = delete;
  cv::Size size() const { return size_; }
  const ExrAttributes& attributes() const { return attrs_; }
  cv::Mat1f rows(int y0, int n);

 private:
  struct File;
  std::unique_ptr<File> file_;
  fs::path path_;
  cv::Size size_;
  ExrAttributes attrs_;
};
// The ground size of a pixel an EXR states (reefgen:metres_per_pixel, or
// reefgen:metres_per_px as infer wrote it before 2026-11-23); 0 when it
// states none or no positive finite number.
double exr_metres_per_px(const ExrAttributes& attrs);

// An image file a sketch can be read from, by extension (case-insensitive).
inline bool is_image(const fs::path& p) {
  std::string e = p.extension().string();
  for (auto& ch : e) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  return e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".tif" || e == ".tiff" || e == ".bmp" || e == ".webp";
}

// The sketch images directly inside a folder, in name order (the order of
// results and reports).
inline std::vector<fs::path> images_in(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && is_image(e.path())) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace reefgen
