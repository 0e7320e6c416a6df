#pragma once
// The dataset layouts other tools read (docs/DATASET.md "Layouts for other
// tools"): pix2pix's aligned A|B images, WebDataset tar shards and Hugging
// Face's image folder. Same pairs, same determinism and resume rules as
// reefgen's own layout; the encoders are pure functions of the pair.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

namespace reefgen::augment {

enum class DatasetLayout { Reefgen, Pix2pix, WebDataset, ImageFolder };
// "reefgen" | "pix2pix" | "webdataset" | "imagefolder"; throws Error listing them.
DatasetLayout layout_from_string(const std::string& s);
const char* to_string(DatasetLayout l);

// A float32 (H, W) array as numpy's .npy (format 1.0, little-endian '<f4').
std::string npy_bytes(const cv::Mat1f& values);

// pix2pix's aligned image: A (the label map) | B (the heights in grey), one
// 16-bit RGB PNG of 2S x S. Heights map linearly: floor_m -> 0, peak_m ->
// 65535. Readers that take 8 bits (PIL, so pix2pix's aligned mode) see the
// high byte: A exactly, B over the same range in 256 steps.
std::string aligned_png16(const cv::Mat3b& label_bgr, const cv::Mat1f& height_m, double floor_m, double peak_m);

// Where a tar's bytes go: a new file, or a comparison with the file a
// previous run finished (a resumed build verifies it without rewriting it).
class ByteSink {
 public:
  virtual ~ByteSink() = default;
  virtual void put(const char* data, size_t n) = 0;
};

// A POSIX ustar archive written as a stream: fixed owner, mode and time, so
// the same members give the same bytes (WebDataset reads it with Python's
// tarfile). Names are at most 99 bytes.
class TarWriter {
 public:
  explicit TarWriter(ByteSink& sink) : sink_(sink) {}
  void add(const std::string& name, const std::string& bytes);
  void finish();  // the two zero blocks that end an archive

 private:
  ByteSink& sink_;
};

// The bytes one WebDataset sample of a side-S pair can take at most in a
// tar: what fixes the number of pairs per shard before any is generated.
size_t tar_sample_bound(int size_px);

}  // namespace reefgen::augment
