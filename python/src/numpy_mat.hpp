#pragma once
// OpenCV images as numpy arrays without a copy, for both Python modules.
#include <pybind11/numpy.h>

#include <string>
#include <utility>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/error.hpp"
#include "reefgen/labels.hpp"

namespace reefgen::python {

// A numpy array over the Mat's pixels, owning a reference to them.
// Mat1f -> (H, W) float32; Mat3b -> (H, W, 3) uint8.
template <class T>
pybind11::array_t<T> to_numpy(cv::Mat m) {
  namespace py = pybind11;
  CV_Assert(m.isContinuous());
  auto* owned = new cv::Mat(std::move(m));
  py::capsule owner(owned, [](void* p) { delete static_cast<cv::Mat*>(p); });
  const py::ssize_t H = owned->rows, W = owned->cols, C = owned->channels(), item = sizeof(T);
  if (C == 1) return py::array_t<T>({H, W}, {W * item, item}, owned->ptr<T>(), owner);
  return py::array_t<T>({H, W, C}, {W * C * item, C * item, item}, owned->ptr<T>(), owner);
}

// The sketch as OpenCV holds an image it read: (H, W) grey, (H, W, 3) RGB or
// (H, W, 4) RGBA, 8 or 16 bits -> the same depth in BGR(A) for decode_sketch.
inline cv::Mat bgr_of(const pybind11::array& sketch, const std::string& who) {
  namespace py = pybind11;
  const bool u8 = py::isinstance<py::array_t<uint8_t>>(sketch), u16 = py::isinstance<py::array_t<uint16_t>>(sketch);
  const int channels = sketch.ndim() == 2 ? 1 : sketch.ndim() == 3 ? int(sketch.shape(2)) : 0;
  if (!(u8 || u16) || !(channels == 1 || channels == 3 || channels == 4))
    throw Error(who + ": the sketch must be a (H, W, 3) RGB or (H, W, 4) RGBA array of uint8 or uint16 "
                "(a painted label map: PIL's np.asarray(Image.open(path)))");
  const int rows = int(sketch.shape(0)), cols = int(sketch.shape(1));
  if (rows < 1 || cols < 1)
    throw Error(who + ": the sketch is empty (" + std::to_string(cols) + "x" + std::to_string(rows) +
                "); give a painted label map of at least 1x1 pixels");
  if (rows > kMaxSketchSide || cols > kMaxSketchSide)
    throw Error(who + ": the sketch is " + std::to_string(cols) + "x" + std::to_string(rows) + "; at most " +
                std::to_string(kMaxSketchSide) + " a side");
  const py::array packed = py::array::ensure(sketch, py::array::c_style);
  const cv::Mat view(rows, cols, CV_MAKETYPE(u8 ? CV_8U : CV_16U, channels), const_cast<void*>(packed.data()));
  cv::Mat bgr;
  if (channels == 3) cv::cvtColor(view, bgr, cv::COLOR_RGB2BGR);
  else if (channels == 4) cv::cvtColor(view, bgr, cv::COLOR_RGBA2BGRA);
  else bgr = view.clone();
  return bgr;
}

}  // namespace reefgen::python
