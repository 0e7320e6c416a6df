// Encoders of the layouts other tools read (formats.hpp): .npy, pix2pix's
// aligned A|B PNG and ustar archives, each bytes-for-bytes deterministic.
#include "reefgen/augment/formats.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/image_io.hpp"

namespace reefgen::augment {

namespace {

constexpr size_t kTarBlock = 512;  // ustar's record unit (POSIX.1-1988)

}  // namespace

DatasetLayout layout_from_string(const std::string& s) {
  if (s == "reefgen") return DatasetLayout::Reefgen;
  if (s == "pix2pix") return DatasetLayout::Pix2pix;
  if (s == "webdataset") return DatasetLayout::WebDataset;
  if (s == "imagefolder") return DatasetLayout::ImageFolder;
  throw Error("--format " + s + ": use reefgen, pix2pix, webdataset or imagefolder");
}

const char* to_string(DatasetLayout l) {
  switch (l) {
    case DatasetLayout::Pix2pix: return "pix2pix";
    case DatasetLayout::WebDataset: return "webdataset";
    case DatasetLayout::ImageFolder: return "imagefolder";
    default: return "reefgen";
  }
}

std::string npy_bytes(const cv::Mat1f& values) {
  CV_Assert(values.isContinuous());
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + std::to_string(values.rows) + ", " +
                       std::to_string(values.cols) + "), }";
  // Magic (6) + version (2) + length (2) + header, padded with spaces and a
  // newline to a multiple of 64 bytes (the format's alignment).
  const size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  out += char(header.size() & 0xFF);
  out += char(header.size() >> 8);
  out += header;
  // x86-64 is little-endian: the floats' bytes as they are in memory.
  out.append(reinterpret_cast<const char*>(values.ptr<float>()), values.total() * sizeof(float));
  return out;
}

std::string aligned_png16(const cv::Mat3b& label_bgr, const cv::Mat1f& height_m, double floor_m, double peak_m) {
  CV_Assert(label_bgr.size() == height_m.size() && peak_m > floor_m);
  const int S = label_bgr.rows, W = label_bgr.cols;
  cv::Mat3w ab(S, 2 * W);
  const double scale = 65535.0 / (peak_m - floor_m);
  for (int y = 0; y < S; ++y) {
    const cv::Vec3b* l = label_bgr.ptr<cv::Vec3b>(y);
    const float* h = height_m.ptr<float>(y);
    cv::Vec3w* out = ab.ptr<cv::Vec3w>(y);
    for (int x = 0; x < W; ++x) {
      // ×257 puts the 8-bit value in both bytes: 8-bit readers get it back exactly.
      out[x] = cv::Vec3w(uint16_t(l[x][0] * 257), uint16_t(l[x][1] * 257), uint16_t(l[x][2] * 257));
      const double v = std::clamp(std::round((double(h[x]) - floor_m) * scale), 0.0, 65535.0);
      out[W + x] = cv::Vec3w::all(uint16_t(v));
    }
  }
  // zlib level 1 with the Sub filter and RLE, as reefgen's own label maps:
  // OpenCV's encoder (libpng's filter search) made this layout's build 1.7×
  // slower than reefgen's.
  return encode_png16(ab, 1);
}

void TarWriter::add(const std::string& name, const std::string& bytes) {
  if (name.empty() || name.size() > 99) throw Error("internal: tar member name '" + name + "' is not 1..99 bytes");
  char h[kTarBlock] = {};
  std::memcpy(h, name.data(), name.size());
  std::snprintf(h + 100, 8, "%07o", 0644);                                      // mode
  std::snprintf(h + 108, 8, "%07o", 0);                                         // uid
  std::snprintf(h + 116, 8, "%07o", 0);                                         // gid
  std::snprintf(h + 124, 12, "%011llo", static_cast<unsigned long long>(bytes.size()));  // size
  std::snprintf(h + 136, 12, "%011o", 0);  // mtime: 0, so a rebuild gives the same bytes
  h[156] = '0';                            // a regular file
  std::memcpy(h + 257, "ustar", 6);        // magic "ustar\0"
  std::memcpy(h + 263, "00", 2);           // version
  std::memcpy(h + 265, "reefgen", 7);      // owner's user and group names
  std::memcpy(h + 297, "reefgen", 7);
  // The checksum: the header's byte sum with its own field as 8 spaces.
  std::memset(h + 148, ' ', 8);
  unsigned sum = 0;
  for (unsigned char c : h) sum += c;
  std::snprintf(h + 148, 8, "%06o", sum);
  h[155] = ' ';
  sink_.put(h, kTarBlock);
  sink_.put(bytes.data(), bytes.size());
  static const char zeros[kTarBlock] = {};
  if (const size_t tail = bytes.size() % kTarBlock) sink_.put(zeros, kTarBlock - tail);
}

void TarWriter::finish() {
  static const char zeros[2 * kTarBlock] = {};
  sink_.put(zeros, sizeof zeros);
}

size_t tar_sample_bound(int size_px) {
  const size_t S = size_t(size_px), pixels = S * S;
  // Three members, each a header and at most one block of padding.
  const size_t framing = 3 * 2 * kTarBlock;
  const size_t npy = 128 + pixels * sizeof(float);
  // An 8-bit RGB PNG at worst: raw rows (filter byte + 3 bytes a pixel),
  // deflate's stored-block overhead (5 bytes per 16 KiB) and the chunks.
  const size_t raw = S * (3 * S + 1);
  const size_t png = raw + raw / 16384 * 5 + 1024;
  const size_t json = 4096;  // the sample's record: a few hundred bytes
  return framing + npy + png + json;
}

}  // namespace reefgen::augment
