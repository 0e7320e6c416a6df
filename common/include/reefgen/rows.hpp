#pragma once
// A per-pixel pass over a whole canvas, row by row: the rows in bands on
// OpenCV's threads (cv::setNumThreads, as the blurs), and a host's stop
// (reefgen/interrupt.hpp) read between bands on the calling thread, so an
// 8192² pass of a few seconds stops within one band.
#include <algorithm>

#include <opencv2/core/utility.hpp>

#include "reefgen/interrupt.hpp"

namespace reefgen {

// Rows per band: an 8192-px row of three noise octaves takes ~0.5 ms, so a
// band is tens of milliseconds, and there are enough bands to share.
inline constexpr int kRowsPerBand = 64;

// Runs row(y) for every y in [0, rows). The rows must be independent (each
// reads what it likes but writes only its own row), so the bytes do not
// depend on the thread count.
template <class Row>
void for_each_row(int rows, const Row& row) {
  for (int begin = 0; begin < rows; begin += kRowsPerBand) {
    check_interrupt();
    const int end = std::min(rows, begin + kRowsPerBand);
    cv::parallel_for_(cv::Range(begin, end), [&](const cv::Range& r) {
      for (int y = r.start; y < r.end; ++y) row(y);
    });
  }
}

}  // namespace reefgen
