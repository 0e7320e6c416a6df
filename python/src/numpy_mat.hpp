#pragma once
// OpenCV images as numpy arrays without a copy, for both Python modules.
#include <pybind11/numpy.h>

#include <utility>

#include <opencv2/core.hpp>

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

}  // namespace reefgen::python
