// The ONNX export (model/onnx_export.hpp) run in a second runtime, OpenCV's
// dnn: the shipped model's heights equal reefgen's own float32 answer within
// 5 cm on every painted test sketch, and every layout a generator can have
// (norm × upsample × statistics) equals LibTorch's forward.
#include <gtest/gtest.h>
#include <opencv2/dnn.hpp>

#include "reefgen/error.hpp"
#include "reefgen/model/onnx_export.hpp"
#include "shipped_inputs.hpp"
#include "test_util.hpp"

using namespace reefgen;

namespace {

// The ONNX graph's answer (metres) for a {1,C,S,S} input, through OpenCV's importer.
torch::Tensor run_in_opencv(const std::string& onnx, const torch::Tensor& x) {
  cv::dnn::Net net = cv::dnn::readNetFromONNX(onnx.data(), onnx.size());
  net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  const std::vector<int> dims(x.sizes().begin(), x.sizes().end());
  const torch::Tensor xc = x.contiguous();
  net.setInput(cv::Mat(dims, CV_32F, const_cast<float*>(xc.data_ptr<float>())).clone(), "label");
  const cv::Mat y = net.forward("height_m");
  const std::vector<int64_t> ydims(y.size.p, y.size.p + y.dims);
  return torch::from_blob(const_cast<uchar*>(y.data), ydims, torch::kFloat32).clone();
}

// LibTorch's answer in metres, as the graph decodes it (codec.hpp's map).
torch::Tensor torch_metres(model::UNetGeneratorImpl& g, const torch::Tensor& x, const model::HeightRange& r) {
  return (g.forward(x) + 1) * ((r.hi_m - r.lo_m) / 2) + r.lo_m;
}

}  // namespace

TEST(Onnx, ShippedModelInOpenCvEqualsReefgensFp32Answer) {
  constexpr double kBarM = 0.05;  // the export's bar: 5 cm on a ±5 km range (float32 reorderings are ~1e-3 m)
  model::GeneratorFile gf = test::shipped_generator();
  c10::InferenceMode im;
  const std::string onnx = model::generator_onnx(*gf.g, gf.range, {gf.size_px, false});
  const std::vector<test::PaintedInput> painted = test::painted_inputs_256();
  double worst = 0;
  for (const test::PaintedInput& p : painted) {
    const double err = (run_in_opencv(onnx, p.x) - torch_metres(*gf.g, p.x, gf.range)).abs().max().item<double>();
    EXPECT_LT(err, kBarM) << p.name << ": OpenCV dnn vs LibTorch, metres";
    worst = std::max(worst, err);
  }
  std::cerr << "ONNX in OpenCV dnn vs LibTorch fp32: worst " << worst << " m over " << painted.size() << " sketches\n";
  EXPECT_GE(painted.size(), 10u) << "painted sketches at 256²";
}

// Every norm × upsample, with each sample's own statistics and (BatchNorm)
// with running averages that training moved off their start.
TEST(Onnx, EveryLayoutEqualsLibTorch) {
  torch::manual_seed(3);
  const model::HeightRange range{-100, 300};
  for (const auto norm : {model::Norm::Batch, model::Norm::Instance, model::Norm::None})
    for (const auto up : {model::Upsample::Transpose, model::Upsample::Nearest, model::Upsample::Bilinear})
      for (const bool running : {false, true}) {
        if (running && norm != model::Norm::Batch) continue;
        model::UNetOptions o;
        o.ngf = 4, o.depth = 5, o.norm = norm, o.upsample = up;
        model::UNetGenerator g(o);
        model::init_pix2pix(*g);
        const torch::Tensor x = torch::rand({1, 3, 64, 64}) * 2 - 1;
        g->train(true);
        if (running) {
          torch::NoGradGuard ng;
          for (int i = 0; i < 3; ++i) g->forward(torch::rand({2, 3, 64, 64}) * 2 - 1);
          g->train(false);
        }
        g->set_dropout_enabled(false);
        torch::NoGradGuard ng;
        const std::string onnx = model::generator_onnx(*g, range, {64, running});
        const torch::Tensor ref = torch_metres(*g, x, range);
        const double err = (run_in_opencv(onnx, x) - ref).abs().max().item<double>();
        // 1e-5 of the 400 m span: float32 rounding, far below any wrong op (which is off by metres).
        EXPECT_LT(err, 4e-3) << model::to_string(norm) << " " << model::to_string(up) << (running ? " running" : " batch");
        EXPECT_GT(ref.std().item<double>(), 0.01) << "the net answers something";
        std::cerr << model::to_string(norm) << " " << model::to_string(up) << (running ? " running" : " batch")
                  << ": " << err << " m\n";
      }
}

TEST(Onnx, RefusesASideTheNetCannotTake) {
  model::UNetOptions o;
  o.ngf = 4, o.depth = 5;
  model::UNetGenerator g(o);
  test::expect_error_naming([&] { model::generator_onnx(*g, {}, {100, false}); }, "multiple of 32");
}
