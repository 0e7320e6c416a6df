// reefgen.infer for Python: a painted sketch (numpy) -> heights in metres
// with an exported generator, the same numbers `reefgen infer` writes
// (docs/PYTHON.md). A module of its own because it links LibTorch: `import
// reefgen` stays light and works in a build without LibTorch; reefgen.infer
// loads this one on first use. Python's torch (python3-torch) runs the same
// Debian libtorch, so both live in one process.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <torch/torch.h>

#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/error.hpp"
#include "reefgen/infer/infer.hpp"
#include "reefgen/infer/run.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/parallel.hpp"
#include "interrupt_hook.hpp"
#include "numpy_mat.hpp"

namespace py = pybind11;

namespace {

using namespace reefgen;

// A loaded generator and the lock its oneDNN plans need: two Python threads
// may call infer at once with the GIL released.
struct LoadedModel {
  model::GeneratorFile gen;
  std::filesystem::file_time_type written;
  std::mutex busy;
};

// Generators by path, loaded once (a file rewritten since is loaded again).
LoadedModel& loaded_model(const std::filesystem::path& path) {
  static std::mutex table_lock;
  static std::map<std::string, std::unique_ptr<LoadedModel>> table;
  std::error_code ec;
  const auto written = std::filesystem::last_write_time(path, ec);
  const std::string key = std::filesystem::absolute(path, ec).string();
  std::lock_guard<std::mutex> hold(table_lock);
  auto& slot = table[key];
  if (!slot || slot->written != written) {
    auto m = std::make_unique<LoadedModel>();
    m->gen = model::load_generator(path);
    m->written = written;
    slot = std::move(m);
  }
  return *slot;
}

// The command's flags in a message, as this function's keywords.
std::string python_words(std::string m) {
  for (const auto& [flag, keyword] : {std::pair<std::string, std::string>{"--stochastic", "stochastic=True"},
                                      {"--engine ", "engine="},
                                      {"--precision ", "precision="}})
    for (size_t at; (at = m.find(flag)) != std::string::npos;) m.replace(at, flag.size(), keyword);
  return m;
}

infer::InferOptions options_for(const model::GeneratorFile& gen, int size, uint64_t seed, bool raw,
                                const std::string& precision, const std::string& engine, bool stochastic,
                                double world_size_m, double variation, double age_myr, double maturity) {
  if (!std::isnan(age_myr) && !(age_myr >= 0 && age_myr <= kMaxAgeMyr))
    throw Error("infer: age_myr " + std::to_string(age_myr) + " is outside [0, 60] My (None: the painted brightness)");
  if (!std::isnan(maturity) && !(maturity >= kMinMaturity && maturity <= kMaxMaturity))
    throw Error("infer: maturity " + std::to_string(maturity) + " is outside [0.05, 20] (None: the age's, or the default)");
  infer::InferOptions o;
  o.age_myr = std::isnan(age_myr) ? kNotSet : age_myr;
  o.maturity = std::isnan(maturity) ? kNotSet : maturity;
  o.size_px = size;
  o.seed = seed;
  o.variation = variation;
  o.amplify = !raw;
  o.stochastic = stochastic;
  o.world_size_m = world_size_m;
  try {
    o.precision = infer::precision_from_string(precision);
    o.engine = infer::engine_from_string(engine);
    infer::resolve(o, gen);
  } catch (const Error& e) {
    throw Error("precision/engine: " + python_words(e.what()));
  }
  return o;
}

// `reefgen infer SKETCH --size SIZE --seed SEED [--raw]` -> (H, W) float32 metres;
// variations N > 1 (`--variations N`): a list of N, seeds SEED … SEED + N − 1.
py::object infer_sketch(const py::array& sketch, int size, const std::string& model_path, uint64_t seed, bool raw,
                        const std::string& precision, const std::string& engine, bool stochastic,
                        std::optional<int> threads, std::optional<double> world_size_m, double variation,
                        double age_myr, double maturity, int variations) {
  if (variations < 1 || variations > infer::kMaxVariations)
    throw Error("infer: variations must be in [1, " + std::to_string(infer::kMaxVariations) + "] (as --variations)");
  if (!(variation >= 0 && variation <= 1))
    throw Error("infer: variation must be in [0, 1] (0 = the network's own answer, as --variation)");
  if (size < 0 || size > 8192) throw Error("infer: size " + std::to_string(size) + " is outside [0, 8192] (0 = the sketch's)");
  if (threads && (*threads < 1 || *threads > 256)) throw Error("infer: threads must be in [1, 256]");
  if (world_size_m && !(*world_size_m >= 1 && *world_size_m <= 1e7))
    throw Error("infer: world_size_m must be in [1, 1e7] metres (the canvas width, as --world-size)");
  const cv::Mat image = python::bgr_of(sketch, "infer");
  std::vector<cv::Mat1f> heights;
  {
    py::gil_scoped_release free_python;
    const DecodedSketch decoded = decode_sketch(image, "sketch");
    LoadedModel& m = loaded_model(model::resolve_model_path(model_path));
    std::lock_guard<std::mutex> hold(m.busy);
    const infer::InferOptions o = options_for(m.gen, size, seed, raw, precision, engine, stochastic,
                                                 world_size_m.value_or(kCanvasWorldSizeM), variation, age_myr, maturity);
    // LibTorch's thread count is the process's: this call's, then the caller's again.
    const int before = torch::get_num_threads(), n = threads.value_or(default_threads());
    torch::set_num_threads(n);
    try {
      heights = variations == 1 ? infer::infer_heights(m.gen, {decoded}, o)
                                : infer::infer_variations(m.gen, decoded, o, variations, n);
    } catch (...) {
      torch::set_num_threads(before);
      throw;
    }
    torch::set_num_threads(before);
  }
  if (variations == 1) return python::to_numpy<float>(heights[0]);
  py::list out;
  for (auto& h : heights) out.append(python::to_numpy<float>(h));
  return out;
}

}  // namespace

PYBIND11_MODULE(_reefgen_infer, m) {
  m.doc() = "reefgen.infer's LibTorch half: a sketch to heights with an exported generator (docs/PYTHON.md)";
  // The same reefgen.Error as the core module: one exception type for users.
  static py::handle error_type = py::object(py::module_::import("reefgen._reefgen").attr("Error")).release();
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const c10::Error& e) {
      PyErr_SetString(error_type.ptr(), e.what_without_backtrace());
    } catch (const std::runtime_error& e) {
      // reefgen::Error and the model loader's errors: one line naming the file and the fix.
      PyErr_SetString(error_type.ptr(), e.what());
    } catch (const std::invalid_argument& e) {
      // The engine's refusals (an unknown REEFGEN_WINOGRAD_GEMM): the same one line.
      PyErr_SetString(error_type.ptr(), e.what());
    }
  });
  reefgen::python::install_interrupt_hook();
  m.def("infer", &infer_sketch, py::arg("sketch"), py::arg("size"), py::arg("model"), py::arg("seed"), py::arg("raw"),
        py::arg("precision"), py::arg("engine"), py::arg("stochastic"), py::arg("threads"), py::arg("world_size_m"),
        py::arg("variation"), py::arg("age_myr"), py::arg("maturity"), py::arg("variations"));
}
