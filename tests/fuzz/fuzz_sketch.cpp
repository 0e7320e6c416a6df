// libFuzzer target: the sketch decoder. Any image bytes a user can
// hand to `reefgen infer`: decoded by OpenCV, then decode_sketch. The only
// acceptable failure is reefgen::Error (one line, named); crashes, hangs,
// sanitizer reports and other exceptions are findings.
#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "reefgen/files.hpp"
#include "reefgen/labels.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::vector<uint8_t> bytes(data, data + size);
  cv::Mat img;
  try {
    img = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
    return 0;  // OpenCV's own refusal of a broken file (read_sketch reports it as "not an image")
  }
  if (img.empty() || img.cols > 512 || img.rows > 512) return 0;  // read_sketch bounds the size first
  try {
    const reefgen::DecodedSketch s = reefgen::decode_sketch(img, "fuzz");
    (void)reefgen::encode_labels(s.label, s.subsidence);
  } catch (const reefgen::Error&) {
  }
  return 0;
}
