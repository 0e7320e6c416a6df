// libFuzzer target: the sketch decoder. Any image bytes a user can
// hand to `reefgen infer` or the studio: the header's declared size (PNG,
// JPEG, BMP, WebP, TIFF, read by reefgen's own parsers before anything is
// decoded), the damage checks, OpenCV's decode, then decode_sketch. The only
// acceptable failure is reefgen::Error (one line, named); crashes, hangs,
// sanitizer reports and other exceptions are findings.
#include <cstddef>
#include <cstdint>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "reefgen/files.hpp"
#include "reefgen/image_io.hpp"
#include "reefgen/labels.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    (void)reefgen::declared_image_size(bytes);
    // The studio's bound keeps each input fast; a larger declared side is refused unread.
    const cv::Mat img = reefgen::decode_image(bytes, "fuzz", cv::IMREAD_UNCHANGED, 512);
    if (img.cols > 512 || img.rows > 512) std::abort();  // the header lied and the bound did not hold
    const reefgen::DecodedSketch s = reefgen::decode_sketch(img, "fuzz");
    (void)reefgen::encode_labels(s.label, s.subsidence);
  } catch (const reefgen::Error&) {
  }
  return 0;
}
